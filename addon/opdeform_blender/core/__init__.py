"""bpy-free half of the add-on: pure Python and numpy (locating the compiled module, PC2 files, frame logic,
the in-memory state cache, handle maths, the simulation engine and the tumbling particles' bake).
Unit-testable without Blender."""
