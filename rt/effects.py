"""The ray-traced effects, each one record (its RtPass: rt/shadows.py, reflections.py, gi.py,
ao.py, reference.py), and what the app and the backends read from them: the effects in the
study's order, each one's own image (aux channel, and its channels) and random stream.

An effect may also come from outside rtlab: the modules named in RTLAB_EFFECTS (comma-separated,
importable) are loaded here, each with `PASS` (its RtPass subclass), `embree_trace(rf) -> dict`
(the Embree backend's implementation, as rt/embree/<effect>.py's trace) and `SLANG_SHADER` (the
path of its shader, with the ray generation `<effect>_rays`, for the Slang backend): the app's
modes, the CLI, the viewer, the bench and both backends then have it, with no rtlab file edited
(docs/ARCHITECTURE.md, "How to add a ray-traced pass")."""
from __future__ import annotations

import importlib
import os
import sys

from core.errors import UserError
from rt.ao import AOPass
from rt.gi import GIPass
from rt.pass_base import RtPass
from rt.reference import ReferencePass
from rt.reflections import ReflectionsPass
from rt.shadows import ShadowsPass


def _plugins() -> dict:
    """The RTLAB_EFFECTS modules, by their effect's name; one that cannot be used is left out
    with one line on stderr (the CLI then refuses its pass as unknown)."""
    found = {}
    for name in filter(None, (n.strip() for n in os.environ.get("RTLAB_EFFECTS", "").split(","))):
        try:
            module = importlib.import_module(name)
            if not (isinstance(getattr(module, "PASS", None), type) and issubclass(module.PASS, RtPass)):
                raise UserError("it has no PASS (an RtPass subclass)")
        except Exception as e:  # noqa: BLE001 - a user's module: any failure is theirs, said in one line
            print(f"rtlab: RTLAB_EFFECTS: {name!r} left out: {str(e).splitlines()[0] if str(e) else type(e).__name__}",
                  file=sys.stderr)
            continue
        found[module.PASS.name] = module
    return found


PLUGINS = _plugins()
PASSES = {p.name: p for p in (ShadowsPass, ReflectionsPass, GIPass, AOPass, *(m.PASS for m in PLUGINS.values()),
                              ReferencePass)}
EFFECTS = tuple(PASSES)
# the image each effect makes besides radiance (its pass's writes)
AUX_CHANNEL = {name: p.aux() for name, p in PASSES.items() if p.aux() is not None}
AUX_CHANNELS = {name: p.aux_channels for name, p in PASSES.items()}
STREAM = {name: p.stream for name, p in PASSES.items()}


def radiance_terms(mode: str, options) -> tuple[bool, bool]:
    """What the radiance of a pass mode holds of the first hit's material (RtPass.radiance_terms:
    its albedo as a factor, its emission), for the denoisers to take out and put back."""
    found = PASSES.get(mode)
    return found.radiance_terms(options) if found is not None else (True, True)
