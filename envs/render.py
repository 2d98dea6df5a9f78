"""A fast overhead renderer for the TriPlanarShear envs (Pillow; a frame in a few ms, where matplotlib takes ~170 ms).

The view is v0's (x1 right, x3 up, as the paper's figures): the planes' intersection lines, the hydrostatic reference
path (grey), the contact points' traces (black), the contact triangle (blue) and the load tip (red), with a legend
that says so (drawn once, into the background)."""

from __future__ import annotations

import numpy as np
from PIL import Image, ImageDraw

from triplanar.specimen import Foundation

SIZE = 400
X_RANGE = (-0.22, 0.14)   # m, as v0's view
Z_RANGE = (-0.06, 0.32)
# The legend: colour, line width, meaning (bottom left, where the view has no path).
LEGEND = (((150, 150, 150), 1, "hydrostatic (case C) reference path"), ((0, 0, 0), 2, "contact points' paths"),
          ((31, 119, 180), 1, "block: contact triangle"), ((214, 39, 40), 3, "load tip"))


class Renderer:
    def __init__(self, foundation: Foundation, human: bool = False):
        self.human = human
        self.scale = SIZE / max(X_RANGE[1] - X_RANGE[0], Z_RANGE[1] - Z_RANGE[0])
        self.background = Image.new("RGB", (SIZE, SIZE), (255, 255, 255))
        draw = ImageDraw.Draw(self.background)
        n = foundation.normals
        for i, j in ((0, 1), (1, 2), (2, 0)):  # intersection lines of plane pairs through the origin, seen from above
            d = np.cross(n[i], n[j])
            if abs(d[0]) + abs(d[2]) < 1e-12:
                continue
            d = d / np.hypot(d[0], d[2])
            ends = [self._px(np.array([s * d[0], 0.0, s * d[2]])) for s in (-1.0, 1.0)]
            draw.line(ends, fill=(200, 200, 200), width=1)
        for row, (colour, width, text) in enumerate(LEGEND):
            y = SIZE - 14 * (len(LEGEND) - row) - 4
            draw.line([(8, y + 6), (28, y + 6)], fill=colour, width=width)
            draw.text((34, y), text, fill=(0, 0, 0))
        self._window = None

    def _px(self, p: np.ndarray) -> tuple[float, float]:
        return ((p[0] - X_RANGE[0]) * self.scale, SIZE - (p[2] - Z_RANGE[0]) * self.scale)

    def _pxs(self, points: np.ndarray) -> list[tuple[float, float]]:
        x = (points[:, 0] - X_RANGE[0]) * self.scale
        y = SIZE - (points[:, 2] - Z_RANGE[0]) * self.scale
        return list(zip(x.tolist(), y.tolist()))

    def draw(self, trace: np.ndarray, reference: np.ndarray, load_point: np.ndarray, load_N: float,
             t: float) -> np.ndarray | None:
        image = self.background.copy()
        draw = ImageDraw.Draw(image)
        for i in range(3):
            draw.line(self._pxs(reference[:, i]), fill=(150, 150, 150), width=1)
            if len(trace) > 1:
                draw.line(self._pxs(trace[:, i]), fill=(0, 0, 0), width=2)
        tri = trace[-1][[0, 1, 2, 0]]
        draw.line(self._pxs(tri), fill=(31, 119, 180), width=1)
        tip = self._px(load_point)
        draw.line([(tip[0] - 0.06 * self.scale, tip[1]), tip], fill=(214, 39, 40), width=3)
        draw.ellipse([tip[0] - 3, tip[1] - 3, tip[0] + 3, tip[1] + 3], fill=(214, 39, 40))
        draw.text((5, 5), f"{load_N:g} N, t = {t:.3f} s", fill=(0, 0, 0))
        frame = np.asarray(image)
        if self.human:  # a display exists (the env checked): show it with matplotlib's window
            import matplotlib.pyplot as plt
            if self._window is None:
                plt.ion()
                self._window = plt.imshow(frame)
            else:
                self._window.set_data(frame)
            plt.pause(0.001)
            return None
        return frame

    def close(self) -> None:
        self._window = None
