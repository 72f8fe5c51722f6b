"""The panel's per-frame error plot: core/frame_report.plot drawn into an icon of a preview collection
(``bpy.utils.previews``), shown with ``template_icon``. Works the same in Blender 3.4 to 5.x; the pixels are
made with numpy, so they are the same in background mode (tests read them)."""

import bpy.utils.previews

from ..core import frame_report

SIZE = (240, 80)
_previews = {"collection": None, "key": None}


def preview(rt, frame, tolerance):
    """The plot's ImagePreview for the reports up to ``frame`` (redrawn only when they changed)."""
    frames, errors = rt.engine.reports.series(frame)
    key = (id(rt), frames[-1] if len(frames) else None, len(frames), tolerance)
    p = _previews["collection"].get("error") or _previews["collection"].new("error")
    if key != _previews["key"]:
        img = frame_report.plot(errors, tolerance, *SIZE)
        p.image_size = SIZE
        p.image_pixels_float = img.ravel()
        _previews["key"] = key
    return p


classes = ()


def register():
    _previews["collection"] = bpy.utils.previews.new()


def unregister():
    bpy.utils.previews.remove(_previews["collection"])
    _previews["collection"], _previews["key"] = None, None
