"""Which pybullet renderer draws the top-view camera: the EGL plugin where it loads, else TinyRenderer.

pybullet ships an EGL renderer plugin (``eglRenderer``, OpenGL off-screen; with software Mesa it runs
on llvmpipe, no GPU needed). Once loaded into a physics client, every ``getCameraImage`` of that
client goes through it. It must be loaded right after connecting, before any body is spawned: bodies
loaded earlier are unknown to it and the frame comes back empty. The reference renderer is pybullet's
CPU TinyRenderer, which every pybullet has.

The two do not give pixel-identical frames (measured on this machine, software Mesa 22.3): on the
SGCM table (320 x 320) labels differ only on object borders (0.8 % of the pixels, a pixel more or
less at the edges of cubes and the table), and the RGB differs everywhere: shading and a specular
highlight, the ground's checker, and thin shapes lying on a surface, which EGL does not draw (the
table's grid lines, the robots' dark heading markers). The SGCM state estimate (label centroids,
chromaticity) comes out the same; the role engine's colour tracker finds no robot at all in EGL
frames (it needs the heading markers). Hence TinyRenderer stays the bridge's default and EGL is
opt-in (``camera_renderer``: egl or auto).

``renderer``: ``tiny`` (the reference), ``egl`` (the plugin, or an error) or ``auto`` (the plugin
where it loads, TinyRenderer otherwise, with the reason). This module only decides; the scene
(:mod:`.scene`, which drives pybullet) loads the plugin through the function it passes.
"""
from __future__ import annotations

import importlib.util
from dataclasses import dataclass
from typing import Callable

from .settings import AUTO, EGL, RENDERERS, TINY

__all__ = ['AUTO', 'EGL', 'RENDERERS', 'TINY', 'RendererChoice', 'RendererError', 'choose_renderer',
           'egl_plugin_path']


class RendererError(RuntimeError):
    """The EGL renderer was required and does not load here."""


@dataclass(frozen=True)
class RendererChoice:
    name: str      # TINY or EGL: the renderer in use
    reason: str    # why (requested, loaded, or why the plugin did not load)


def egl_plugin_path() -> str | None:
    """File of pybullet's eglRenderer plugin, None when this pybullet has none."""
    spec = importlib.util.find_spec('eglRenderer')
    return None if spec is None or spec.origin is None else spec.origin


def choose_renderer(requested: str, load_plugin: Callable[[str], int],
                    plugin_path: str | None | Callable[[], str | None] = egl_plugin_path) -> RendererChoice:
    """The renderer of a freshly connected client (before any body is loaded).

    load_plugin(path) loads the EGL plugin into the client and returns its id (< 0: not loaded);
    plugin_path: the plugin's file, or the function finding it.
    """
    if requested not in RENDERERS:
        raise ValueError(f"renderer '{requested}' (expected one of {', '.join(RENDERERS)})")
    if requested == TINY:
        return RendererChoice(TINY, 'requested')
    path = plugin_path() if callable(plugin_path) else plugin_path
    if path is None:
        problem = 'this pybullet has no eglRenderer plugin'
    else:
        try:
            plugin = load_plugin(path)
        except Exception as error:  # pybullet.error
            plugin, path = -1, f'{path} ({error})'
        if plugin >= 0:
            return RendererChoice(EGL, f'eglRenderer plugin loaded ({path})')
        problem = f'the eglRenderer plugin did not load (no EGL display or driver?): {path}'
    if requested == EGL:
        raise RendererError(problem)
    return RendererChoice(TINY, f'fallback: {problem}')
