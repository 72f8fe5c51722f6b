"""bpy half of the add-on. Registered (each with one ``classes`` tuple and register()/unregister() that mirror
each other): properties, operators, panels, handlers and the viewport overlay. Not registered, the glue between
Blender data and core/: runtime (deformation), tumbling_runtime and point_cloud (tumbling particles)."""
