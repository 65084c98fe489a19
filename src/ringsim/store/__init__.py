"""Files ringsim writes and reads: the run file (HDF5) and sweep summaries."""
