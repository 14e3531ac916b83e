"""femb: flexible multibody dynamics."""
