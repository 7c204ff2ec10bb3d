"""qa-app: the desktop application over the engine (PySide6 + pyvistaqt)."""
