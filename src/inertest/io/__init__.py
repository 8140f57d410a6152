"""Reading and writing files: plans (TOML), data (CSV, Parquet, HDF5, .npy, raw), results (JSON).

Everything here is I/O only; numerics live in the core packages. Writers are atomic: a file or
report directory appears complete or not at all.
"""
