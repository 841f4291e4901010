"""What a benchmark run varies: :class:`Config`, the presets, the sweep grids, value parsers."""
from __future__ import annotations

import argparse
import dataclasses
import math


@dataclasses.dataclass(frozen=True)
class Config:
    """One configuration of the AO pipeline (what a sweep row varies).

    Frozen and hashable: equal configurations are one sweep row.

    Attributes
    ----------
    maps : tuple of int
        Zigzag view grid ``(theta, phi)`` (:meth:`pyshadow.ViewSet.zigzag`).
    resolution : int
        Texels per CSM side.
    depth_bits : int
        Stored depth precision, 16 or 32.
    samples : int
        AO samples per pixel.
    filter : str or None
        ``denoise=`` of :meth:`pyshadow.Scene.render` (None: unfiltered AO).
    filtered_lookup : bool
        Filtered CSM lookups (``lookup="vote"`` of :meth:`pyshadow.Scene.visible`
        and of the AO calls).
    """

    maps: tuple
    resolution: int
    depth_bits: int
    samples: int
    filter: str | None = None
    filtered_lookup: bool = False

    @property
    def label(self) -> str:
        """Short name, e.g. ``'64x128 r128 16b s36 bilateral'``."""
        s = f"{self.maps[0]}x{self.maps[1]} r{self.resolution} {self.depth_bits}b s{self.samples}"
        return s + (f" {self.filter}" if self.filter else "") + (" filtered-lookup" if self.filtered_lookup else "")

    @property
    def lookup(self) -> str:
        """The CSM lookup of :meth:`pyshadow.Scene.visible`: 'vote' with filtered lookups, else 'nearest'."""
        return "vote" if self.filtered_lookup else "nearest"

    def as_dict(self) -> dict:
        """The JSON record of results.json and sweep.json (``maps`` as ``'TxP'``)."""
        return {"maps": f"{self.maps[0]}x{self.maps[1]}", "layout": "zigzag",
                "views": self.maps[0] * self.maps[1], "resolution": self.resolution,
                "depth_bits": self.depth_bits, "samples": self.samples, "filter": self.filter,
                "filtered_lookup": self.filtered_lookup}


#: Settings of the two standard runs: ``maps``, ``resolution``, ``depth_bits`` as
#: :class:`Config`, ``size`` (width, height) in pixels, AO ``samples`` per pixel,
#: ``reference_samples`` per pixel of the converged reference, timed ``repeats``.
PRESETS = {
    "default": dict(maps=(64, 128), resolution=128, depth_bits=16, size=(640, 480), samples=36,
                    reference_samples=1024, repeats=5),
    "quick": dict(maps=(32, 64), resolution=128, depth_bits=16, size=(320, 240), samples=36,
                  reference_samples=512, repeats=3),
}

#: Sweep grids: rows as overrides of the base configuration (the run's settings).
#: One knob at a time, then a few combinations; 'tiny' is for tests.
SWEEP_GRIDS = {
    "full": [
        {},
        {"maps": (16, 32)}, {"maps": (32, 64)}, {"maps": (128, 256)},
        {"resolution": 64}, {"resolution": 256},
        {"depth_bits": 32},
        {"samples": 4}, {"samples": 16}, {"samples": 64}, {"samples": 144}, {"samples": 256},
        {"filter": "bilateral"},
        {"samples": 16, "filter": "bilateral"},
        {"maps": (32, 64), "samples": 16, "filter": "bilateral"},
        {"maps": (32, 64), "resolution": 64, "samples": 16, "filter": "bilateral"},
        {"maps": (16, 32), "resolution": 64, "samples": 4, "filter": "bilateral"},
        {"samples": 144, "filter": "bilateral"},
        {"resolution": 256, "samples": 144},
        {"filtered_lookup": True},
        {"samples": 144, "filtered_lookup": True},
    ],
    "quick": [
        {},
        {"maps": (16, 32)}, {"maps": (64, 128)},
        {"resolution": 64}, {"resolution": 256},
        {"depth_bits": 32},
        {"samples": 4}, {"samples": 16}, {"samples": 64}, {"samples": 144},
        {"filter": "bilateral"},
        {"samples": 16, "filter": "bilateral"},
        {"maps": (16, 32), "resolution": 64, "samples": 4, "filter": "bilateral"},
        {"filtered_lookup": True},
    ],
    "tiny": [
        {}, {"samples": 4}, {"filter": "bilateral"}, {"maps": (4, 8)}, {"depth_bits": 32}, {"filtered_lookup": True},
    ],
}


def _config_of(d: dict) -> Config:
    """The :class:`Config` of a ``Config.as_dict()`` record."""
    return Config(tuple(int(x) for x in d["maps"].split("x")), d["resolution"], d["depth_bits"],
                  d["samples"], d["filter"], bool(d.get("filtered_lookup", False)))


# argparse ``type=`` parsers: each returns the value or raises ArgumentTypeError quoting the text
def _pair(text: str, what: str, lo: int, hi: int):
    """``'AxB'`` -> ``(a, b)``, both integers in ``lo..hi``."""
    parts = text.lower().split("x")
    try:
        a, b = (int(p) for p in parts)
    except ValueError:
        raise argparse.ArgumentTypeError(f"expected {what} as AxB (e.g. 64x128), got {text!r}") from None
    if not (lo <= a <= hi and lo <= b <= hi):
        raise argparse.ArgumentTypeError(f"{what} must be between {lo} and {hi} each, got {text!r}")
    return a, b


def _maps(text):
    return _pair(text, "maps (zigzag theta x phi)", 1, 4096)


def _size(text):
    return _pair(text, "image size WIDTHxHEIGHT", 1, 16384)


def _int_range(lo, hi, what):
    def parse(text):
        try:
            v = int(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"{what} must be an integer, got {text!r}") from None
        if not lo <= v <= hi:
            raise argparse.ArgumentTypeError(f"{what} must be in {lo}..{hi}, got {v}")
        return v
    return parse


def positive_number(not_a_number: str, not_positive: str, hi=None):
    """An argparse type for a finite number > 0; the messages are formatted with ``text``.

    ``hi``: optional ``(largest, message)``, a larger value refused with the
    message formatted with ``text`` and ``hi``.
    """
    def parse(text):
        try:
            v = float(text)
        except ValueError:
            raise argparse.ArgumentTypeError(not_a_number.format(text=text)) from None
        if not (math.isfinite(v) and v > 0):
            raise argparse.ArgumentTypeError(not_positive.format(text=text))
        if hi is not None and v > hi[0]:
            raise argparse.ArgumentTypeError(hi[1].format(text=text, hi=hi[0]))
        return v
    return parse


_positive_float = positive_number("expected a number, got {text!r}", "must be a positive finite number, got {text!r}")
