"""Scenario and sweep files: YAML -> validated, frozen objects (upstream end of the data
path)."""
