#!/usr/bin/env python3
"""Writes the shipped view paths (tests/load/*_explore.jsonl) for `zoomwarp replay`.

Each path is a person exploring one sample image on a 480x360 screen: starting from the whole
image, they visit a few hand-chosen points of interest in turn. A visit zooms in on the point in
wheel notches of 0.05 with the cursor on it (so the point stays put and the view glides towards
it), drags around it in small successive moves, then zooms out part of the way or fully; when
the next point is off screen they drag towards it first. Every path ends at zoom 0.

Deterministic: the same output on every run and Python 3 version (only random.Random(seed).random()
is used, whose sequence Python guarantees). Run from anywhere:

    python3 tests/load/make_view_paths.py

The view geometry is an approximation of the server's geometric zoom curve (warp/core/zoom_curve.h),
one screen pixel covering (image/screen)^(1-z) image pixels on each axis; it only shapes the path
(how far a drag moves, where the view must stay), the server computes the real views.
"""

import json
import math
import os
import random
from dataclasses import dataclass

SCREEN_W, SCREEN_H = 480, 360  # zoomwarp replay's default screen, so the lines leave w, h out
NOTCHES = 20                   # wheel notches from zoom 0 to 1: 0.05 each
DRAG_STEP = (15, 40)           # screen pixels between two moves of a drag
LOOP_RADIUS = 180              # screen pixels: how far the drags around a point wander
STROKES = 4                    # drags around each point, before the one back to it


@dataclass
class Visit:
    what: str
    x: float
    y: float
    peak: int     # notches zoomed in at the point (20 = zoom 1, full resolution)
    out_to: int   # notches to zoom out to afterwards


@dataclass
class Exploration:
    name: str
    image: str
    width: int
    height: int
    seed: int
    visits: list


EXPLORATIONS = [
    Exploration("boats_explore", "boats_lake_sunset.jpg", 2560, 1600, 1, [
        Visit("the number '27 00 Carry 4' on the front boat", 212, 1250, 20, 10),
        Visit("the oars in the middle boat", 962, 950, 17, 9),
        Visit("the jetty posts in the lake", 1725, 662, 19, 0),
        Visit("the boathouse on the far shore", 212, 580, 18, 10),
        Visit("the bare tree on the right shore", 2400, 500, 20, 0),
    ]),
    Exploration("pano_explore", "pano_grossmugl_field_4to1.png", 2048, 512, 2, [
        Visit("the burial mound", 637, 46, 20, 10),
        Visit("the benches below the mound", 757, 81, 20, 8),
        Visit("the village on the horizon", 431, 52, 18, 0),
        Visit("the hedge along the ploughed field", 1306, 157, 17, 10),
        Visit("the trees on the right horizon", 1946, 63, 20, 0),
    ]),
    Exploration("interior_explore", "interior_wine_djembe_tall.jpg", 2560, 3837, 3, [
        Visit("the wine bottle's label", 1260, 1000, 20, 10),
        Visit("the coffee grinder", 2060, 920, 19, 9),
        Visit("the loudspeaker", 200, 740, 18, 0),
        Visit("the djembe's rope lacing", 640, 2480, 20, 10),
        Visit("the lower shelf of the pallet table", 2000, 1680, 16, 0),
    ]),
]


class Viewer:
    """The view of one person, and the actions it has sent so far."""

    def __init__(self, ex):
        self.ex = ex
        self.rng = random.Random(ex.seed)
        self.notch = 0
        self.cx, self.cy = ex.width / 2, ex.height / 2
        self.actions = []
        self.emit("zoom")  # the first view: the whole image

    def uniform(self, lo, hi):
        return lo + (hi - lo) * self.rng.random()

    def scale(self, notch):
        """Image pixels per screen pixel on each axis at a zoom of `notch` notches."""
        z = notch / NOTCHES
        return (max(1, self.ex.width / SCREEN_W) ** (1 - z), max(1, self.ex.height / SCREEN_H) ** (1 - z))

    def inside(self, x, y):
        """The view centre nearest to (x, y) whose view stays inside the image, as viewers keep it
        (the server requires the centre inside)."""
        sx, sy = self.scale(self.notch)
        half_w, half_h = SCREEN_W * sx / 2, SCREEN_H * sy / 2
        w, h = self.ex.width, self.ex.height
        return (w / 2 if 2 * half_w >= w else min(max(x, half_w), w - half_w),
                h / 2 if 2 * half_h >= h else min(max(y, half_h), h - half_h))

    def emit(self, action):
        self.actions.append({"action": action, "zoom": round(self.notch / NOTCHES, 2),
                             "cx": round(self.cx), "cy": round(self.cy)})

    def wheel_to(self, notch, x, y):
        """Wheel notches up to `notch` with the cursor on image point (x, y), which stays put."""
        while self.notch != notch:
            before = self.scale(self.notch)
            self.notch += 1 if notch > self.notch else -1
            after = self.scale(self.notch)
            self.cx, self.cy = self.inside(x + (self.cx - x) * after[0] / before[0],
                                           y + (self.cy - y) * after[1] / before[1])
            self.emit("zoom")

    def drag_towards(self, x, y, close_enough):
        """Drags the view centre towards image point (x, y), or as near as the image edges let
        it, in small wobbly moves until it is within `close_enough` screen pixels."""
        sx, sy = self.scale(self.notch)
        x, y = self.inside(x, y)
        while True:
            dx, dy = (x - self.cx) / sx, (y - self.cy) / sy  # in screen pixels
            distance = math.hypot(dx, dy)
            if distance <= close_enough:
                return
            step = min(distance, self.uniform(*DRAG_STEP))
            angle = math.atan2(dy, dx) + self.uniform(-0.3, 0.3)
            self.cx, self.cy = self.inside(self.cx + step * math.cos(angle) * sx,
                                           self.cy + step * math.sin(angle) * sy)
            self.emit("pan")

    def look_around(self, v):
        """Drags in a loop around the point, then back to it."""
        sx, sy = self.scale(self.notch)
        start = self.uniform(0, 2 * math.pi)
        for i in range(STROKES):
            angle = start + 2 * math.pi * i / STROKES
            self.drag_towards(v.x + LOOP_RADIUS * math.cos(angle) * sx,
                              v.y + LOOP_RADIUS * math.sin(angle) * sy, DRAG_STEP[1])
        self.drag_towards(v.x, v.y, DRAG_STEP[1])

    def visit(self, v):
        # The point must be on screen to put the cursor on it: drag it into view first.
        self.drag_towards(v.x, v.y, 0.35 * min(SCREEN_W, SCREEN_H))
        self.wheel_to(v.peak, v.x, v.y)
        self.look_around(v)
        self.wheel_to(v.out_to, self.cx, self.cy)


def header(ex, count):
    lines = [f"{ex.name}.jsonl: {count} actions of a person exploring samples/{ex.image} "
             f"({ex.width}x{ex.height}) on a {SCREEN_W}x{SCREEN_H} screen.",
             "Generated by tests/load/make_view_paths.py (do not edit by hand); points of interest:"]
    lines += [f"  {v.what} at ({v.x}, {v.y}), zoom {v.peak / NOTCHES:g}, then out to {v.out_to / NOTCHES:g}"
              for v in ex.visits]
    return "".join(f"# {line}\n" for line in lines)


def main():
    here = os.path.dirname(os.path.abspath(__file__))
    for ex in EXPLORATIONS:
        viewer = Viewer(ex)
        for v in ex.visits:
            viewer.visit(v)
        path = os.path.join(here, ex.name + ".jsonl")
        with open(path, "w") as out:
            out.write(header(ex, len(viewer.actions)))
            for a in viewer.actions:
                out.write(json.dumps(a) + "\n")
        print(f"{path}: {len(viewer.actions)} actions")


if __name__ == "__main__":
    main()
