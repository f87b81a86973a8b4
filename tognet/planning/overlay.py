"""Draw a user plan on its depth image: the chosen grasp, the alternatives and a legend (PNG)."""

from __future__ import annotations

import io

import numpy as np
from numpy.typing import NDArray

from tognet.grasping.draw import depth_to_rgb, jaw_endpoints
from tognet.planning.user import UserPlan

#: Colours of the chosen grasp (first) and the alternatives, in order.
COLOURS = ((255, 40, 40), (255, 160, 0), (80, 200, 255), (200, 90, 255), (90, 230, 90), (255, 255, 255))


def render_plan(plan: UserPlan, depth: NDArray[np.float32], opening: float = 0.08) -> bytes:
    """PNG bytes of ``depth`` (metres, NaN holes) with the plan's grasps drawn as open jaws (``opening``
    metres apart, a dot on phi's positive finger), numbered 1 (the chosen one, thickest) to K + 1, and a
    legend with each one's scores and action, the table's estimate and the warnings."""
    from PIL import Image, ImageDraw, ImageFont

    camera = plan.camera
    if camera is None:
        raise ValueError("the plan does not carry its camera intrinsics")
    h, w = depth.shape
    scale = 2 if w <= 800 else 1
    # Grey: how far in front of the table (along each ray), black at the table, white at 1.2 x the object's
    # top (seen at the tilt): the same contrast anywhere on a tilted table.
    tilt = np.cos(np.radians(plan.plane.tilt))
    span = max(1.2 * float(plan.object.get("height_m", 0.04)), 0.02) / max(tilt, 0.5)
    table = plan.plane.depth_of_rays(camera.intrinsics)
    img = Image.fromarray(depth_to_rgb(depth, table, span)).resize((w * scale, h * scale),
                                                                  Image.Resampling.NEAREST)
    draw = ImageDraw.Draw(img)
    font = ImageFont.load_default(size=11 * scale)
    grasps = [plan.grasp, *plan.alternatives]
    table = np.array([g.table for g in grasps])
    ends = jaw_endpoints(camera, table, np.full(len(grasps), opening)) * scale
    for i in reversed(range(len(grasps))):  # the chosen grasp drawn last, on top
        colour = COLOURS[min(i, len(COLOURS) - 1)]
        (u0, v0), (u1, v1) = ends[i]
        width = (4 if i == 0 else 2) * scale // 2 + 1
        draw.line([(u0, v0), (u1, v1)], fill=colour, width=width)
        r = (5 if i == 0 else 3) * scale // 2 + 1
        draw.ellipse([u1 - r, v1 - r, u1 + r, v1 + r], fill=colour)
        cu, cv = grasps[i].pixel * scale
        draw.text((cu + 4, cv + 4), str(i + 1), fill=colour, font=font)
    lines: list[tuple[str, tuple[int, int, int]]] = [
        (f"{plan.method} plan, {plan.task}: {plan.candidates} candidates, "
         f"{1000 * plan.timing.get('total', 0.0):.0f} ms", (255, 255, 255)),
    ]
    for i, g in enumerate(grasps):
        a = g.action
        name = "chosen" if i == 0 else "alternative"
        lines.append((f"{i + 1} {name}: {g.describe_scores()}; "
                      f"action ({a[0]:+.3f}, {a[1]:+.3f}, {a[2]:+.3f} m, {a[3]:+.2f} rad)",
                      COLOURS[min(i, len(COLOURS) - 1)]))
    p = plan.plane
    lines.append((f"table {'fitted' if p.fitted else 'from the camera pose'}: camera {p.offset:.3f} m above, "
                  f"tilted {p.tilt:.1f} deg", (200, 200, 200)))
    o = plan.object
    lines.append((f"object #{o.get('index', 0)} of {len(plan.objects)} at pixel ({o['pixel'][0]:.0f}, "
                  f"{o['pixel'][1]:.0f}): {o.get('why', '')}", (200, 200, 200)))
    lines.extend((f"warning: {text}", (255, 255, 0)) for text in plan.warnings)
    pad = 3 * scale
    heights = [draw.textbbox((0, 0), t, font=font)[3] + pad for t, _ in lines]
    widths = [draw.textbbox((0, 0), t, font=font)[2] for t, _ in lines]
    box = (0, 0, min(img.width, max(widths) + 2 * pad), sum(heights) + pad)
    overlay = Image.new("RGBA", img.size, (0, 0, 0, 0))
    ImageDraw.Draw(overlay).rectangle(box, fill=(0, 0, 0, 170))
    img = Image.alpha_composite(img.convert("RGBA"), overlay)
    draw = ImageDraw.Draw(img)
    y = pad
    for (text, colour), dy in zip(lines, heights, strict=True):
        draw.text((pad, y), text, fill=colour, font=font)
        y += dy
    buf = io.BytesIO()
    img.convert("RGB").save(buf, format="PNG")
    return buf.getvalue()
