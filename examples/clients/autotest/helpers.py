"""A few helpers written after ArduPilot's Tools/autotest/vehicle_test_suite.py (the names and
the way they wait are autotest's: change_mode, wait_mode, wait_altitude, wait_statustext,
wait_ready_to_arm, set_parameter, set_rc, arm_vehicle, wait_disarmed), for the autotest-style
programs beside this file. Each raises AutoTestTimeoutException on timeout, as autotest does.

Every program takes the device as argv[1] (default tcp:127.0.0.1:5760).
"""
import math
import sys
import time

from pymavlink import mavutil

mavlink = mavutil.mavlink


class AutoTestTimeoutException(Exception):
    pass


class Vehicle:
    """A pymavlink connection and autotest's waits on it (GCS heartbeats sent while waiting)."""

    def __init__(self, device=None):
        self.mav = mavutil.mavlink_connection(device or (sys.argv[1] if len(sys.argv) > 1 else "tcp:127.0.0.1:5760"))
        self.mav.wait_heartbeat(timeout=30)
        self.send_heartbeats = True
        self._last_hb = 0
        self.statustexts = []
        self.mav.mav.request_data_stream_send(self.mav.target_system, self.mav.target_component,
                                              mavlink.MAV_DATA_STREAM_ALL, 10, 1)

    def progress(self, text):
        print(f"AT-{time.time():.1f}: {text}", flush=True)

    def recv(self, types, timeout=1.0):
        if self.send_heartbeats and time.time() - self._last_hb > 0.5:
            self.mav.mav.heartbeat_send(mavlink.MAV_TYPE_GCS, mavlink.MAV_AUTOPILOT_INVALID, 0, 0, 0)
            self._last_hb = time.time()
        if isinstance(types, str):
            types = [types]
        msg = self.mav.recv_match(type=list(types) + ["STATUSTEXT"], blocking=True, timeout=timeout)
        if msg is not None and msg.get_type() == "STATUSTEXT":
            self.statustexts.append(msg.text)
            self.progress(f"AP: {msg.text}")
            return msg if "STATUSTEXT" in types else None
        return msg

    def wait_until(self, types, cond, timeout, what):
        end = time.time() + timeout
        while time.time() < end:
            m = self.recv(types, timeout=0.5)
            if m is not None and cond(m):
                return m
        raise AutoTestTimeoutException(f"Failed to attain {what}")

    def run_cmd(self, cmd, p1=0, p2=0, p3=0, p4=0, p5=0, p6=0, p7=0, want_result=mavlink.MAV_RESULT_ACCEPTED, timeout=10):
        self.mav.mav.command_long_send(self.mav.target_system, self.mav.target_component, cmd, 0, p1, p2, p3, p4, p5, p6, p7)
        ack = self.wait_until("COMMAND_ACK", lambda a: a.command == cmd, timeout, f"COMMAND_ACK for {cmd}")
        if want_result is not None and ack.result != want_result:
            raise ValueError(f"command {cmd} result {ack.result}, wanted {want_result}")
        return ack.result

    def set_parameter(self, name, value):
        for _ in range(3):
            self.mav.mav.param_set_send(self.mav.target_system, self.mav.target_component, name.encode(), value,
                                        mavlink.MAV_PARAM_TYPE_REAL32)
            try:
                got = self.wait_until("PARAM_VALUE", lambda p: p.param_id == name, 3, f"PARAM_VALUE {name}")
            except AutoTestTimeoutException:
                continue
            if abs(got.param_value - value) < 1e-4 * max(1, abs(value)):
                self.progress(f"set {name} to {value}")
                return
        raise ValueError(f"Param fetch returned incorrect value for {name}")

    def get_parameter(self, name):
        self.mav.mav.param_request_read_send(self.mav.target_system, self.mav.target_component, name.encode(), -1)
        return self.wait_until("PARAM_VALUE", lambda p: p.param_id == name, 5, f"PARAM_VALUE {name}").param_value

    def mode_name(self):
        hb = self.wait_until("HEARTBEAT", lambda h: h.get_srcComponent() == 1, 5, "HEARTBEAT")
        return mavutil.mode_mapping_acm.get(hb.custom_mode, str(hb.custom_mode))

    def change_mode(self, mode, timeout=30):
        number = self.mav.mode_mapping()[mode]
        end = time.time() + timeout
        while time.time() < end:
            self.mav.set_mode(number)
            if self.mode_name() == mode:
                self.progress(f"Got mode {mode}")
                return
        raise AutoTestTimeoutException(f"Failed to change mode to {mode}")

    def wait_mode(self, mode, timeout=60):
        self.wait_until("HEARTBEAT", lambda h: h.get_srcComponent() == 1
                        and mavutil.mode_mapping_acm.get(h.custom_mode) == mode, timeout, f"mode {mode}")
        self.progress(f"Got mode {mode}")

    def armed(self):
        hb = self.wait_until("HEARTBEAT", lambda h: h.get_srcComponent() == 1, 5, "HEARTBEAT")
        return bool(hb.base_mode & mavlink.MAV_MODE_FLAG_SAFETY_ARMED)

    def wait_ready_to_arm(self, timeout=120):
        """SYS_STATUS says pre-arm good and EKF_STATUS_REPORT has the flags autotest requires."""
        required = (mavlink.EKF_ATTITUDE | mavlink.ESTIMATOR_VELOCITY_HORIZ | mavlink.ESTIMATOR_VELOCITY_VERT
                    | mavlink.ESTIMATOR_POS_HORIZ_REL | mavlink.ESTIMATOR_POS_HORIZ_ABS
                    | mavlink.ESTIMATOR_POS_VERT_ABS | mavlink.ESTIMATOR_PRED_POS_HORIZ_REL
                    | mavlink.ESTIMATOR_PRED_POS_HORIZ_ABS)
        error_bits = mavlink.ESTIMATOR_CONST_POS_MODE | mavlink.ESTIMATOR_ACCEL_ERROR
        self.wait_until("EKF_STATUS_REPORT", lambda e: (e.flags & required) == required and not e.flags & error_bits,
                        timeout, "EKF flags")
        self.progress("EKF flags OK")
        self.wait_until("SYS_STATUS", lambda s: s.onboard_control_sensors_health & mavlink.MAV_SYS_STATUS_PREARM_CHECK,
                        timeout, "pre-arm checks")
        self.progress("Ready to arm")

    def arm_vehicle(self):
        self.run_cmd(mavlink.MAV_CMD_COMPONENT_ARM_DISARM, 1)
        self.wait_until("HEARTBEAT", lambda h: h.get_srcComponent() == 1
                        and h.base_mode & mavlink.MAV_MODE_FLAG_SAFETY_ARMED, 10, "armed")
        self.progress("ARMED")

    def wait_disarmed(self, timeout=120):
        self.wait_until("HEARTBEAT", lambda h: h.get_srcComponent() == 1
                        and not h.base_mode & mavlink.MAV_MODE_FLAG_SAFETY_ARMED, timeout, "disarm")
        self.progress("DISARMED")

    def altitude(self):
        return self.wait_until("GLOBAL_POSITION_INT", lambda m: True, 5, "GLOBAL_POSITION_INT").relative_alt / 1000.0

    def wait_altitude(self, alt_min, alt_max, timeout=60, minimum_duration=0):
        start_ok = None
        end = time.time() + timeout
        while time.time() < end:
            alt = self.altitude()
            if alt_min <= alt <= alt_max:
                start_ok = start_ok or time.time()
                if time.time() - start_ok >= minimum_duration:
                    self.progress(f"Altitude OK {alt:.1f}")
                    return alt
            else:
                start_ok = None
        raise AutoTestTimeoutException(f"Failed to attain altitude {alt_min}..{alt_max}")

    def distance_from_home(self):
        home = getattr(self, "_home", None)
        pos = self.wait_until("GLOBAL_POSITION_INT", lambda m: True, 5, "GLOBAL_POSITION_INT")
        if home is None:
            self._home = home = (pos.lat * 1e-7, pos.lon * 1e-7)
        dn = (pos.lat * 1e-7 - home[0]) * 111319.5
        de = (pos.lon * 1e-7 - home[1]) * 111319.5 * math.cos(math.radians(home[0]))
        return math.hypot(dn, de)

    def wait_statustext(self, text, timeout=30, regex=False, check_context=True):
        import re
        if check_context and any((re.search(text, t) if regex else text in t) for t in self.statustexts):
            return
        self.wait_until("STATUSTEXT", lambda m: re.search(text, m.text) if regex else text in m.text,
                        timeout, f"statustext {text!r}")

    def set_rc(self, chan, pwm, hold=1.0):
        """autotest's set_rc, through RC_CHANNELS_OVERRIDE (towerlink has no SITL RC input port);
        the override lasts RC_OVERRIDE_TIME (3 s) after the last one, then the receiver's pulse is back."""
        rc = [65535] * 18
        rc[chan - 1] = pwm
        end = time.time() + hold
        while time.time() < end:
            self.mav.mav.rc_channels_override_send(self.mav.target_system, self.mav.target_component, *rc)
            self.recv("HEARTBEAT", timeout=0.1)

    def takeoff(self, alt, mode="GUIDED"):
        self.change_mode(mode)
        self.wait_ready_to_arm()
        self.arm_vehicle()
        self.run_cmd(mavlink.MAV_CMD_NAV_TAKEOFF, p7=alt)
        self.wait_altitude(alt - 1, alt + 5, timeout=60)

    def fly_guided_to_local(self, north, east, up):
        self.mav.mav.set_position_target_local_ned_send(0, self.mav.target_system, self.mav.target_component,
                                                        mavlink.MAV_FRAME_LOCAL_NED, 0b110111111000,
                                                        north, east, -up, 0, 0, 0, 0, 0, 0, 0, 0)

    def do_RTL(self, timeout=120):
        self.change_mode("RTL")
        self.wait_altitude(-1, 0.5, timeout=timeout)
        self.wait_disarmed(timeout=timeout)

    def upload_items(self, items, mission_type=mavlink.MAV_MISSION_TYPE_MISSION):
        """items: (command, frame, p1, p2, p3, p4, lat, lon, alt) tuples; seq 0 included."""
        m = self.mav
        m.mav.mission_count_send(m.target_system, m.target_component, len(items), mission_type)
        while True:
            req = self.wait_until(["MISSION_REQUEST", "MISSION_REQUEST_INT", "MISSION_ACK"], lambda r: True, 10,
                                  "mission request")
            if req.get_type() == "MISSION_ACK":
                self.progress(f"MISSION_ACK {req.type}")
                return req.type
            cmd, frame, p1, p2, p3, p4, lat, lon, alt = items[req.seq]
            m.mav.mission_item_int_send(m.target_system, m.target_component, req.seq, frame, cmd, 0, 1,
                                        p1, p2, p3, p4, int(lat * 1e7), int(lon * 1e7), alt, mission_type)


def run(test):
    """Run test(vehicle); print PASS or the failure, exit accordingly (as autotest reports)."""
    v = Vehicle()
    try:
        test(v)
    except Exception as exc:  # noqa: BLE001 - reported, as autotest reports a failed test
        print(f"FAILED: {type(exc).__name__}: {exc}", flush=True)
        sys.exit(1)
    print("PASSED", flush=True)
