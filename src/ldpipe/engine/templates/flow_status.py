"""Template: how a trajectory of :func:`ldpipe.core.trajectories.integrate` ended, the drivers' ``o_status``.

Constants only, so that the flow drivers (``flow_driver.py``, ``vector_field_driver.py``'s
``vector_field_crossings``) and :mod:`ldpipe.core.trajectories`, which imports this module as is, read the
same codes.
"""

FLOW_COMPLETED = 0  # the whole duration integrated
FLOW_ESCAPED = 1  # stopped where a coordinate first passed the escape radius (or started beyond it)
FLOW_CROSSINGS_FULL = 2  # stopped at the last section crossing wanted
FLOW_STEP_UNDERFLOW = 3  # failed: a step size underflow, the step cap, or a state not finite
FLOW_RUNNING = -1  # not an outcome: the trajectory goes on (within a driver only)
# The outcomes' names by code from 0, as a CF ``flag_meanings`` attribute.
FLOW_STATUS_MEANINGS = "completed escaped crossings_full step_underflow"
