"""What the viewer (v: app/viewer.Viewer) draws over its image with ImGui: the status lines
that name what is on screen, and the split view's divider and labels."""
from __future__ import annotations


def status_overlay(v, imgui) -> None:
    """Never an old image under a new name: while the image on screen is of another scene or
    pass than the one selected, it is dimmed and says so; while a frame is traced, which one,
    and how far accumulation has come."""
    io = imgui.get_io()
    w, h = io.display_size.x, io.display_size.y
    right = v.split * w if v.comparison is not None else w
    want = f"{v.scene.name}: {v.pass_name}"
    draw = imgui.get_background_draw_list()
    lines = []
    if v.warmup is not None:
        lines.append(v.warmup.status)
    if v.main.shown_label and v.main.shown_label != want:
        draw.add_rect_filled((0, 0), (right, h), imgui.get_color_u32((0.0, 0.0, 0.0, 0.55)))
        lines.append(f"old image: {v.main.shown_label}")
        lines.append(f"tracing {want}...")
    elif v.main.busy and v.renderer.frame_count == 0:
        lines.append(f"tracing {want}...")
    limit = int(v.options.get("max_frames"))
    if v.main.busy and limit and v.renderer.frame_count < limit:
        fps = v.main.shown_fps()
        eta = f", {(limit - v.renderer.frame_count) / fps:.0f} s left" if fps > 0 else ""
        lines.append(f"frame {v.renderer.frame_count} of {limit}{eta}")
    y = h / 2 - 12 * len(lines)
    for text in lines:
        size = imgui.calc_text_size(text)
        x = max((right - size.x) / 2, 4)
        draw.add_rect_filled((x - 6, y - 3), (x + size.x + 6, y + size.y + 3),
                             imgui.get_color_u32((0.0, 0.0, 0.0, 0.75)))
        draw.add_text((x, y), imgui.get_color_u32((1.0, 0.85, 0.4, 1.0)), text)
        y += size.y + 10

def split_overlay(v, imgui) -> None:
    """The divider (drag it with the left mouse button) and each side's label."""
    io = imgui.get_io()
    scale = io.display_framebuffer_scale.x or 1.0
    width = io.display_size.x
    x = v.split * width
    mouse = io.mouse_pos
    near = abs(mouse.x - x) < 6 and 0 <= mouse.y < io.display_size.y
    if imgui.is_mouse_clicked(0) and near and not io.want_capture_mouse:
        v.dragging_split = True
    if not imgui.is_mouse_down(0):
        v.dragging_split = False
    if v.dragging_split and width > 0:
        v.split = float(min(max(mouse.x / width, 0.0), 1.0))
    draw = imgui.get_foreground_draw_list()
    colour = imgui.get_color_u32((1.0, 1.0, 1.0, 1.0 if (near or v.dragging_split) else 0.8))
    draw.add_line((x, 0), (x, io.display_size.y), colour, 2.0 * scale)
    left = f"{v.pass_name}: {v.renderer.frame_count} frames"
    y = io.display_size.y - 24
    dark = imgui.get_color_u32((0.0, 0.0, 0.0, 0.7))
    for text, at_x in ((left, 8), (v.comparison.label, None)):
        size = imgui.calc_text_size(text)
        tx = at_x if at_x is not None else width - size.x - 8
        draw.add_rect_filled((tx - 4, y - 2), (tx + size.x + 4, y + size.y + 2), dark)
        draw.add_text((tx, y), imgui.get_color_u32((1.0, 1.0, 1.0, 1.0)), text)
