"""Which objects of a scene have oriented particles enabled: the handlers walk this list on every frame
instead of every object of the scene. It is refreshed only when marked dirty: Enable's update (properties.py),
a file load, undo, an object renamed during a bake, and when the scene's count of objects changed (a copy of an
enabled object, Shift+D, is enabled too)."""

_discovery = {"dirty": True, "names": {}}


def mark_discovery():
    _discovery["dirty"] = True


def enabled_objects(scene):
    """The scene's objects with oriented particles enabled (the list is refreshed only when marked dirty)."""
    names = _discovery["names"]
    if _discovery["dirty"]:
        names.clear()
        _discovery["dirty"] = False
    key, count = scene.name, len(scene.objects)
    if names.get(key, (None,))[0] != count:
        names[key] = (count, [o.name for o in scene.objects if o.type == 'MESH' and o.opdeform.enabled])
    out = []
    for name in names[key][1]:
        obj = scene.objects.get(name)
        if obj is None or not obj.opdeform.enabled:
            mark_discovery()
            continue
        out.append(obj)
    return out
