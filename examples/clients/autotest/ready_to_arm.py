#!/usr/bin/env python3
"""autotest's wait_ready_to_arm (EKF_STATUS_REPORT flags, SYS_STATUS pre-arm bit), then arm in
GUIDED and disarm on the ground, as every autotest flight starts."""
from helpers import mavlink, run


def test(v):
    v.wait_ready_to_arm()
    v.change_mode("GUIDED")
    v.arm_vehicle()
    v.run_cmd(mavlink.MAV_CMD_COMPONENT_ARM_DISARM, 0)
    v.wait_disarmed(timeout=10)


run(test)
