"""The PARAM_SETs a vehicle fault sends, as bytes: from the tower's system id and a component
of their own (FAULTS_COMPONENT), MAVLink 2 signed with the run's key when it has one, so a
vehicle that takes only signed packets takes these too (they are the simulator's, like SITL's
SIM_* parameters set from a script)."""
from __future__ import annotations

from common.mavlink.ids import TOWER_SYSID
from tools.fault_timeline import ParamSet

FAULTS_COMPONENT = 202      # beside the tower (190), the van's driver (200): a stream of its own
SIGNING_LINK_ID = 3         # the tower signs on 2, the vehicles and the bridge on 0 and 1


class ParamSetEncoder:
    """`encoder(ParamSet) -> bytes`: one PARAM_SET frame for the fault's vehicle (component 1)."""

    def __init__(self, signing_key: bytes | None = None) -> None:
        from common.mavlink.dialect import encoder
        self.mav = encoder(TOWER_SYSID, FAULTS_COMPONENT)
        if signing_key:
            from common.mavlink.signing import setup_signing
            setup_signing(self.mav, signing_key, SIGNING_LINK_ID)

    def __call__(self, p: ParamSet) -> bytes:
        from common.mavlink.dialect import towerlink as tl
        msg = tl.MAVLink_param_set_message(p.sysid, 1, p.name.encode(), float(p.value), p.ptype)
        data = msg.pack(self.mav)
        self.mav.seq = (self.mav.seq + 1) % 256
        return bytes(data)
