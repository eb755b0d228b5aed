"""The ray-traced effects, each one record (its RtPass: rt/shadows.py, reflections.py, gi.py,
ao.py, reference.py), and what the app and the backends read from them: the effects in the
study's order, each one's own image (aux channel, and its channels) and random stream."""
from __future__ import annotations

from rt.ao import AOPass
from rt.gi import GIPass
from rt.reference import ReferencePass
from rt.reflections import ReflectionsPass
from rt.shadows import ShadowsPass

PASSES = {p.name: p for p in (ShadowsPass, ReflectionsPass, GIPass, AOPass, ReferencePass)}
EFFECTS = tuple(PASSES)
# the image each effect makes besides radiance (its pass's writes)
AUX_CHANNEL = {name: p.aux() for name, p in PASSES.items() if p.aux() is not None}
AUX_CHANNELS = {name: p.aux_channels for name, p in PASSES.items()}
STREAM = {name: p.stream for name, p in PASSES.items()}
