"""The small core every stage shares: data types and frames, results, geometry, errors, paths, run files."""
