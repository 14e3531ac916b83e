"""femb element library (installed as ``femb.elements``)."""
