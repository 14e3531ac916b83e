"""femb benchmark scenes (installed as ``femb.benchmarks``)."""
