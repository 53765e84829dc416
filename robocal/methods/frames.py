"""The measurement frame: registering the nominal robot in it, which every method that
models a residual error starts from, and which is the baseline ("registered nominal")
every method is scored against."""
from ..estimation.metrics import error_stats
from ..estimation.registration import register_base_and_tool
from .base import REGISTER

# With the right robot and unit, nominal FK lands within a few mm of a tracker reading in the
# robot base frame; tens of mm mean the readings are in another frame (tracker, world).
REGISTER_ABOVE_RMS_MM = 25.0


def measurement_frame(chain, joints, positions, register="auto"):
    """The nominal ``chain`` in the frame of the measured ``positions`` (N, 3) mm at ``joints``
    (N, n) rad: base and tool registered when ``register`` is 'yes', or 'auto' and the
    nominal RMS error exceeds REGISTER_ABOVE_RMS_MM; as given when 'no'.

    Returns (chain, dict with ``registered``, ``nominal_in_given_frame`` and, when registered,
    the registration's ``iterations``).
    """
    REGISTER.check(register)
    before = error_stats(positions - chain.fk_positions(joints))
    do_it = register == "yes" or (register == "auto" and before.rms_mm > REGISTER_ABOVE_RMS_MM)
    record = {"registered": bool(do_it), "nominal_in_given_frame": before.to_dict()}
    if do_it:
        chain, report = register_base_and_tool(chain, joints, positions)
        record["iterations"] = report.iterations
    return chain, record


def registered_nominal(chain, joints, positions):
    """The nominal geometry with base and tool registered to the data: the simplest model,
    and the "before" of every method's figures."""
    return register_base_and_tool(chain, joints, positions)[0]
