"""Template: the step control of every driver: whether a trajectory starts, and its step sizes.

The LD block driver (``driver.py``), the flow driver (``flow_driver.py``) and the first-order
driver of general flows (``vector_field_driver.py``) share it:

* ``start_outcome``: a trajectory starts only from a finite state inside the region and the
  escape radius;
* Hairer's starting step (Solving ODEs I, II.4);
* after an attempt with scaled error err (accepted when err <= 1), |h| times
  SAFETY err^ERROR_EXPONENT clipped to [MIN_FACTOR, MAX_FACTOR], without growth right after
  a rejection; a step below MIN_STEP max(1, tau) ends the trajectory as failed.

The starting step takes norms of the state and of its derivative, which differ in form: the
Hamiltonian drivers hold (q, p) with q' = p and p' = a(q) (Nyström form), the first-order
one x with x' = f(x, t). Each form's ``initial_step`` (``driver.py``,
``vector_field_driver.py``) computes its norms and hands them to ``trial_step`` and
``starting_step`` here.

Header and template names used: ORDER, ``inside`` (``events.py``).
"""
# ruff: noqa: F821  (the upper-case constants, njit and JIT come from the generated module)

SAFETY = 0.9
MIN_FACTOR = 0.2
MAX_FACTOR = 10.0
MIN_STEP = 1e-13  # relative to max(1, tau): a smaller |h| has underflowed
# The error estimate of a step of order ORDER scales as |h| ** (ORDER + 1).
ERROR_EXPONENT = -1.0 / (ORDER + 1.0)

# Whether a trajectory starts (start_outcome)
START = 0
START_OUTSIDE_REGION = 1
START_ESCAPED = 2
START_FAILED = 3


@njit(**JIT)
def start_outcome(finite, xv, lo, hi, has_region, elo, ehi):
    """START, or why a trajectory from a state (``finite``: all its values are; xv its first
    N, the coordinates the boxes bound) does not start: not finite (START_FAILED), outside
    the region box [lo, hi] (START_OUTSIDE_REGION, with ``has_region``), beyond the escape
    radius, the box [elo, ehi] (START_ESCAPED)."""
    if not finite:
        return START_FAILED
    if has_region and not inside(xv, lo, hi):
        return START_OUTSIDE_REGION
    if not inside(xv, elo, ehi):
        return START_ESCAPED
    return START


@njit(**JIT)
def clipped_step(habs, elapsed, tau):
    """|h| = habs cut to what remains of the duration tau after |t| = elapsed."""
    remaining = tau - elapsed
    return remaining if habs > remaining else habs


@njit(**JIT)
def error_factors(err):
    """The factors of |h| after an attempt with scaled error err: (if accepted, if rejected).
    A NaN or infinite error (e.g. a non-finite state) rejects by the smallest factor."""
    scaled = SAFETY * err**ERROR_EXPONENT if err > 0.0 else MAX_FACTOR
    grow = min(MAX_FACTOR, scaled)
    shrink = max(MIN_FACTOR, scaled) if (err < math.inf and err > 0.0) else MIN_FACTOR
    return grow, shrink


@njit(**JIT)
def accepted_step(habs, grow, after_rejection):
    """|h| after an accepted step: habs times ``error_factors``' grow, at most 1 right after a rejection."""
    factor = min(1.0, grow) if after_rejection else grow
    return habs * factor


@njit(**JIT)
def underflow(habs, tau):
    """Whether |h| = habs has become too small to go on over a duration tau."""
    return habs < MIN_STEP * max(1.0, tau)


@njit(**JIT)
def step_after(habs, err, accepted, after_rejection, tau):
    """(|h| of the next attempt, whether it has underflowed) after an attempt of |h| = habs
    with scaled error err."""
    grow, shrink = error_factors(err)
    if accepted:
        return accepted_step(habs, grow, after_rejection), False
    habs = habs * shrink
    return habs, underflow(habs, tau)


@njit(**JIT)
def advance(elapsed, habs, tau):
    """(|t| at the end of an accepted step of |h| = habs from |t| = elapsed, whether it is the
    last): the last step ends at tau exactly."""
    last = habs >= tau - elapsed
    return (tau if last else elapsed + habs), last


@njit(**JIT)
def trial_step(d0, d1, tau):
    """Hairer's trial step h0 from the norms d0 of the state and d1 of its derivative, at most tau."""
    h0 = 1e-6 if (d0 < 1e-5 or d1 < 1e-5) else 0.01 * d0 / d1
    return min(h0, tau)


@njit(**JIT)
def starting_step(h0, d1, d2, tau):
    """Hairer's starting step from the trial step h0, d1 and d2, the norm of the derivative's
    change over the trial step divided by h0."""
    if d1 <= 1e-15 and d2 <= 1e-15:
        h1 = max(1e-6, h0 * 1e-3)
    else:
        h1 = (0.01 / max(d1, d2)) ** (1.0 / (ORDER + 1.0))
    return min(100.0 * h0, h1, tau)
