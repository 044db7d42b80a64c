"""The HDF5 session file: its schema, the crash-safe writer and recorder, and the reader."""
