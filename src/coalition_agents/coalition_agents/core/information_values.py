"""Evaluating a local coalition solution on values: what its schemas compute while it runs (no ROS).

A :class:`~.coalition_solution.LocalCoalitionSolution` fixes which sensor, which teammate's offer and which
RPS provide each instance; while the coalition executes, information flows along that tree
(Section IV-C: "each edge represents an information instance that constantly flows from the
output of one node into the input of another"). :func:`evaluate` computes the values along it:

* an ES-EPS leaf: the robot's own latest reading of that instance (``own``);
* a prior (dummy sensor): the a-priori value (``priors``);
* a CS leaf: the latest value the providing teammate streamed (``streamed``);
* an RPS: :data:`CONVERSIONS` by schema name, on the planar values of
  :mod:`.transport.information_stream`;
* a reply's root CS passes its input on; an MS root yields its inputs' values.

A value that cannot be computed now (no reading, stale stream, a conversion that needs a heading
nobody measured) raises :class:`ValueUnavailable` naming the instance and why.

Headings (our choice; the paper's F_G is a position): a fiducial measures a position, not the seen
robot's orientation, so F_G of a robot localised through a teammate's fiducial has no ``yaw``. A
robot's motor schema estimates its own heading from its motion (:mod:`.motor_schema`) and passes
it in ``headings``: a conversion that needs the heading of an entity whose F_G value has none
uses it.
"""
from __future__ import annotations

import math
from typing import Callable, Mapping, Sequence

from .coalition_solution import LocalCoalitionSolution
from .errors import RequestError
from .information import InformationInstance
from .schemas import SchemaKind
from .solution_space import SolutionStep

Value = Mapping[str, float]


class ValueUnavailable(RequestError):
    """A value a solution needs cannot be computed now (the message says which and why)."""


def _rotate(x: float, y: float, angle: float) -> tuple[float, float]:
    c, s = math.cos(angle), math.sin(angle)
    return c * x - s * y, s * x + c * y


def wrap(angle: float) -> float:
    """``angle`` in (-pi, pi]."""
    return math.atan2(math.sin(angle), math.cos(angle))


def _heading(instance: InformationInstance, value: Value, headings: Mapping[str, float]) -> float:
    """The heading of F_G(X)'s X: measured, else the motor schema's estimate."""
    if 'yaw' in value:
        return value['yaw']
    name = str(instance.referents[0])
    if name in headings:
        return headings[name]
    raise ValueUnavailable(f'{instance}: the heading of {name} is not known (its position comes from a fiducial, '
                           f'which measures no orientation, and no heading estimate was given)')


def global_from_relative(inputs: Sequence[tuple[InformationInstance, Value]], headings: Mapping[str, float]) -> dict:
    """Table I: F_G(X) + F_R(Y, X) => F_G(Y): Y = X + R(yaw_X) r."""
    (g_label, g), (_, r) = inputs
    yaw = _heading(g_label, g, headings)
    dx, dy = _rotate(r['x'], r['y'], yaw)
    out = {'x': g['x'] + dx, 'y': g['y'] + dy}
    if 'yaw' in r:
        out['yaw'] = wrap(yaw + r['yaw'])
    return out


def relative_inverse(inputs: Sequence[tuple[InformationInstance, Value]], headings: Mapping[str, float]) -> dict:
    """Table I: F_R(Y, X) => F_R(X, Y): X in Y's frame = -R(-theta) r, theta = Y's heading in X's frame."""
    (label, r), = inputs
    if 'yaw' not in r:
        raise ValueUnavailable(f'{label}: inverting a relative position needs the relative heading, which this '
                               f'measurement does not have')
    x, y = _rotate(-r['x'], -r['y'], -r['yaw'])
    return {'x': x, 'y': y, 'yaw': wrap(-r['yaw'])}


def relative_composition(inputs: Sequence[tuple[InformationInstance, Value]], headings: Mapping[str, float]) -> dict:
    """Table I: F_R(X, Z) + F_R(Y, Z) => F_R(X, Y) = R(-theta_Y)(r_X - r_Y)."""
    (_, rx), (label_y, ry) = inputs
    if 'yaw' not in ry:
        raise ValueUnavailable(f'{label_y}: composing relative positions needs its relative heading')
    x, y = _rotate(rx['x'] - ry['x'], rx['y'] - ry['y'], -ry['yaw'])
    out = {'x': x, 'y': y}
    if 'yaw' in rx:
        out['yaw'] = wrap(rx['yaw'] - ry['yaw'])
    return out


def torque_from_force(inputs: Sequence[tuple[InformationInstance, Value]], headings: Mapping[str, float]) -> dict:
    """Fig. 4 ([32]): F_F(X) + F_R(X, Y) => F_T(X, Y) = r x f, f along X's heading in Y's frame."""
    (_, f), (label, r) = inputs
    if 'yaw' not in r:
        raise ValueUnavailable(f'{label}: a torque needs the pushing direction (relative heading)')
    fx, fy = f['force'] * math.cos(r['yaw']), f['force'] * math.sin(r['yaw'])
    return {'torque': r['x'] * fy - r['y'] * fx}


Conversion = Callable[[Sequence[tuple[InformationInstance, Value]], Mapping[str, float]], dict]
#: RPS name (schemas.yaml) -> value conversion.
CONVERSIONS: dict[str, Conversion] = {
    'global_from_relative': global_from_relative,
    'relative_inverse': relative_inverse,
    'relative_composition': relative_composition,
    'torque_from_force': torque_from_force,
}

#: (provider, instance) -> value: how :func:`evaluate` reads streamed values.
StreamLookup = Callable[[str, InformationInstance], Value | None]
#: instance -> value: the robot's own current readings.
OwnLookup = Callable[[InformationInstance], Value | None]


def evaluate(lcs: LocalCoalitionSolution, own: OwnLookup, streamed: StreamLookup,
             priors: Mapping[InformationInstance, Value] | None = None,
             headings: Mapping[str, float] | None = None) -> dict[InformationInstance, dict]:
    """The values of the root's inputs (for an MS root) or of the answer (for a reply), keyed by
    their absolute instances (see the module docstring)."""
    priors = priors or {}
    headings = headings or {}
    sources = iter(lcs.sources)

    def value_of(step: SolutionStep) -> tuple[InformationInstance, dict]:
        if step.is_leaf:
            _, instance, offer = next(sources)
            if step.kind is SchemaKind.CS:
                found = streamed(offer.provider, offer.instance)
                why = f'no current value streamed by {offer.provider}'
                instance = offer.instance
            elif step.kind is SchemaKind.PRIOR:
                found, why = priors.get(instance), 'no a-priori value configured'
            else:
                found, why = own(instance), f'no current {step.schema} reading'
            if found is None:
                raise ValueUnavailable(f'{instance}: {why}')
            return instance, dict(found)
        inputs = [value_of(child) for child in step.inputs]
        output = lcs.instantiate(step.output) if step.output is not None else None
        if step.kind is SchemaKind.RPS:
            conversion = CONVERSIONS.get(step.schema)
            if conversion is None:
                raise ValueUnavailable(f'{output}: RPS {step.schema} has no value conversion '
                                       f"(known: {', '.join(CONVERSIONS)})")
            return output, conversion(inputs, headings)  # type: ignore[return-value]
        return output, inputs[0][1]  # a reply's root CS passes its input on

    root = lcs.potential_solution.root
    if root.kind is SchemaKind.MS:
        return dict(value_of(child) for child in root.inputs)
    instance, value = value_of(root)
    return {instance: value}


__all__ = ['CONVERSIONS', 'ValueUnavailable', 'evaluate', 'global_from_relative', 'relative_composition',
           'relative_inverse', 'torque_from_force', 'wrap']
