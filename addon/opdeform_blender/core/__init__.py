"""bpy-free half of the add-on: pure Python and numpy (locating the compiled module, PC2 files, frame logic,
the in-memory state cache, handle maths and the simulation engine). Unit-testable without Blender."""
