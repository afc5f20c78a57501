#!/usr/bin/env python3
"""Parameters and a mission with MAVSDK 4.x's native API: set and read back a float and an int
parameter, upload a mission_raw (home, TAKEOFF, two waypoints, RTL), download it and compare.

Usage: params_mission_v4.py [ADDRESS]
"""
import sys

from mavsdk import ComponentType, Configuration, Mavsdk
from mavsdk.plugins.mission_raw import MissionItem, MissionRaw
from mavsdk.plugins.param import Param

ADDRESS = sys.argv[1] if len(sys.argv) > 1 else "udpin://0.0.0.0:14540"
HOME = (-35.363261, 149.165230)


def item(seq, frame, command, lat=0.0, lon=0.0, alt=0.0):
    return MissionItem(seq=seq, frame=frame, command=command, current=1 if seq == 0 else 0, autocontinue=1,
                       param1=0, param2=0, param3=0, param4=0, x=int(lat * 1e7), y=int(lon * 1e7), z=alt,
                       mission_type=0)


sdk = Mavsdk(Configuration.create_with_component_type(ComponentType.GROUND_STATION))
sdk.add_any_connection(ADDRESS)
system = sdk.first_autopilot(20.0)
if system is None:
    raise SystemExit("no autopilot")
print("-- Connected to drone!")
param, mission = Param(system), MissionRaw(system)
param.set_param_float("WPNAV_SPEED", 650.0)
print(f"WPNAV_SPEED = {param.get_param_float('WPNAV_SPEED')}")
param.set_param_int("RTL_ALT", 2000)
print(f"RTL_ALT = {param.get_param_int('RTL_ALT')}")
items = [item(0, 0, 16, *HOME), item(1, 3, 22, alt=10), item(2, 3, 16, HOME[0] + 2e-4, HOME[1], 10),
         item(3, 3, 16, HOME[0] + 2e-4, HOME[1] + 2e-4, 10), item(4, 3, 20)]
mission.upload_mission(items)
print("-- Mission uploaded")
got = mission.download_mission()
same = [(g.seq, g.command, g.x, g.y) for g in got[1:]] == [(i.seq, i.command, i.x, i.y) for i in items[1:]]
print(f"-- Mission downloaded: {len(got)} items, {'same' if same else 'DIFFERENT'}")
