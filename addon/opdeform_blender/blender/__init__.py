"""bpy half of the add-on: properties, operators, panels, handlers and the viewport overlay. Each module has
one ``classes`` tuple and register()/unregister() that mirror each other."""
