"""REBOUND machinery: the native library, the resolver handle, the sheet builder, the
time-step policy and the run loop."""
