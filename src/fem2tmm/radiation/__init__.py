"""Radiation stage: quasi-Monte Carlo ray tracing of radiative exchange factors (thesis ch. 2 and 5, DESIGN §3.5).

Modules: ``engine`` (Embree / numpy closest hit), ``sampling`` (scrambled Halton, area-preserving triangle map,
cosine directions), ``surfaces`` (two-sided faces with optics, ray scene, super-face emission tables),
``tracer`` (bounce loop, exchange factors, accuracy control), ``smoothing`` (reciprocity, closure, LSE),
``quadric`` (Taubin fit, foot-point projection, ray-quadric roots, :class:`QuadricScene` for curved super faces),
``solar`` (solar fluxes), ``reference`` (closed-form view factors and REFs), ``_tracer_kernels`` (the compiled
per-ray kernels).  The benchmarks live in the checkout's ``benchmarks/`` (``fem2tmm bench rays``).
"""

from __future__ import annotations

from .engine import HAS_EMBREE
from .quadric import Quadric, fit_quadric, fit_regions
from .quadric_scene import QuadricScene
from .surfaces import Surface, TriangleScene
from .tracer import ExchangeResult, exchange_factors, trace_exchange, trace_paths

__all__ = ["HAS_EMBREE", "Surface", "TriangleScene", "ExchangeResult", "exchange_factors", "trace_exchange",
           "trace_paths", "Quadric", "QuadricScene", "fit_quadric", "fit_regions"]
