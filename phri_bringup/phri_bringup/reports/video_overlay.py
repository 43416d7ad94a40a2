"""Text overlay of the video frames: a few lines in a dark box, top left (Pillow + the DejaVu Sans
font that matplotlib ships, so no new font or dependency)."""

from __future__ import annotations

from functools import cache
from typing import Any

import numpy as np
from numpy.typing import NDArray

OVERLAY_MARGIN = 10
"""Distance of the box from the frame's corner and of the text from the box's edge [px]."""


@cache
def _font(size: int) -> Any:
    from matplotlib import font_manager
    from PIL import ImageFont

    return ImageFont.truetype(font_manager.findfont("DejaVu Sans"), size)


def overlay_lines(
    t: float,
    waist_force: float | None,
    waist_psi: float | None,
    robot_yaw: float | None,
    partner_yaw: float | None,
    waist_link: str,
) -> list[str]:
    """The overlay's text: sim time [s], the waist force [N] and priority weight ψ (15) of the
    waist link, the headings of robot base and partner [deg] (``None`` = not recorded: "–")."""

    def num(value: float | None, fmt: str) -> str:
        return "–" if value is None else format(value, fmt)

    return [
        f"t = {t:5.1f} s",
        f"waist force ({waist_link}): {num(waist_force, '5.1f')} N   ψ = {num(waist_psi, '.2f')}",
        f"heading: robot {num(robot_yaw, '+4.0f')}°   partner {num(partner_yaw, '+4.0f')}°",
    ]


def draw_overlay(frame: NDArray[np.uint8], lines: list[str]) -> NDArray[np.uint8]:
    """``frame`` (H×W×3 uint8) with ``lines`` written into a half-transparent dark box at the
    bottom left; font size scales with the frame height (16 px at 576 px)."""
    from PIL import Image, ImageDraw

    font = _font(max(10, round(frame.shape[0] * 16 / 576)))
    m = OVERLAY_MARGIN
    line_h = int(font.size * 1.35)
    width = 2 * m + max((int(font.getlength(line)) for line in lines), default=0)
    height = line_h * len(lines) + m
    height, width = min(height, frame.shape[0] - m), min(width, frame.shape[1] - m)
    top = frame.shape[0] - m - height
    region = frame[top:top + height, m:m + width]  # only the box is composited: fast
    box = Image.new("RGBA", (width, height), (0, 0, 0, 140))
    draw = ImageDraw.Draw(box)
    for i, line in enumerate(lines):
        draw.text((m, m // 2 + i * line_h), line, font=font, fill=(255, 255, 255, 255))
    out = frame.copy()
    out[top:top + height, m:m + width] = np.asarray(
        Image.alpha_composite(Image.fromarray(region).convert("RGBA"), box).convert("RGB"))
    return out
