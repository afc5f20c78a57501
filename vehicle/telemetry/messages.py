"""The message families of vehicle/telemetry/ for one vehicle, by MAVLink message id.

`message_builders(ap, clock)` gives msgid -> builder: each builder returns the message's
field values in pymavlink's constructor order (a list of them for PID_TUNING, one message per
enabled axis, as ArduPilot sends them together), or None when the vehicle has nothing to say
now (FENCE_STATUS with the fence off, a rover's NAV_CONTROLLER_OUTPUT outside autopilot
modes, POSITION_TARGET_GLOBAL_INT without a destination, PID_TUNING with GCS_PID_MASK 0,
SCALED_PRESSURE3 of SITL's two barometers, a rover's WIND and ATTITUDE_TARGET). Nothing is
computed until a stream or a request calls a builder.
"""
from __future__ import annotations

from collections.abc import Callable

from pymavlink.dialects.v20 import ardupilotmega as mav

from vehicle.telemetry.controllers import ControllerTelemetry
from vehicle.telemetry.ekf_status import EkfTelemetry
from vehicle.telemetry.imu import ImuTelemetry
from vehicle.telemetry.navigation import NavigationTelemetry
from vehicle.telemetry.outputs import OutputsTelemetry
from vehicle.telemetry.system import SystemTelemetry
from vehicle.telemetry.truth import TruthTelemetry

Builder = Callable[[], "tuple | None"]


def message_builders(ap, clock: Callable[[], float]) -> dict[int, Builder]:
    """msgid -> field builder for vehicle `ap` (its autopilot); clock() is sim time (s).
    Nothing of `ap` is read before a builder runs."""
    imu, ekf = ImuTelemetry(ap, clock), EkfTelemetry(ap)
    out, nav, board = OutputsTelemetry(ap, clock), NavigationTelemetry(ap, clock), SystemTelemetry(ap)
    truth, ctrl = TruthTelemetry(ap), ControllerTelemetry(ap, clock)
    builders: dict[int, Builder] = {
        mav.MAVLINK_MSG_ID_RAW_IMU: imu.raw_imu_fields,
        mav.MAVLINK_MSG_ID_SCALED_IMU2: imu.scaled_imu2_fields,
        mav.MAVLINK_MSG_ID_SCALED_IMU3: imu.scaled_imu3_fields,
        mav.MAVLINK_MSG_ID_SCALED_PRESSURE: imu.scaled_pressure_fields,
        mav.MAVLINK_MSG_ID_SCALED_PRESSURE2: imu.scaled_pressure2_fields,
        mav.MAVLINK_MSG_ID_SCALED_PRESSURE3: imu.scaled_pressure3_fields,
        mav.MAVLINK_MSG_ID_SIMSTATE: truth.simstate_fields,
        mav.MAVLINK_MSG_ID_SIM_STATE: truth.sim_state_fields,
        mav.MAVLINK_MSG_ID_WIND: truth.wind_fields,
        mav.MAVLINK_MSG_ID_PID_TUNING: ctrl.pid_tuning_fields,
        mav.MAVLINK_MSG_ID_ATTITUDE_TARGET: ctrl.attitude_target_fields,
        mav.MAVLINK_MSG_ID_VIBRATION: imu.vibration_fields,
        mav.MAVLINK_MSG_ID_EKF_STATUS_REPORT: ekf.ekf_status_report_fields,
        mav.MAVLINK_MSG_ID_AHRS: ekf.ahrs_fields,
        mav.MAVLINK_MSG_ID_AHRS2: ekf.ahrs2_fields,
        mav.MAVLINK_MSG_ID_SERVO_OUTPUT_RAW: out.servo_output_raw_fields,
        mav.MAVLINK_MSG_ID_RC_CHANNELS: out.rc_channels_fields,
        mav.MAVLINK_MSG_ID_ESC_TELEMETRY_1_TO_4: out.esc_telemetry_1_to_4_fields,
        mav.MAVLINK_MSG_ID_NAV_CONTROLLER_OUTPUT: nav.nav_controller_output_fields,
        mav.MAVLINK_MSG_ID_POSITION_TARGET_GLOBAL_INT: nav.position_target_global_int_fields,
        mav.MAVLINK_MSG_ID_POWER_STATUS: board.power_status_fields,
        mav.MAVLINK_MSG_ID_MEMINFO: board.meminfo_fields,
        mav.MAVLINK_MSG_ID_FENCE_STATUS: board.fence_status_fields,
        # Rover's SERVO_OUT (ArduCopter accepts the id too, and has nothing to send)
        mav.MAVLINK_MSG_ID_RC_CHANNELS_SCALED: out.rc_channels_scaled_fields,
    }
    return builders
