"""Independent reference models (checks, never the thing tested)."""
