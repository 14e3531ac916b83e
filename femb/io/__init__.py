"""Output layer: VTK time series and rendering (the only layer that imports meshio/pyvista)."""
