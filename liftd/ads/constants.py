"""ADS/AMS wire constants (reference/ads.md §1–§3; AdsLib AdsDef.h; Beckhoff Infosys "ADS Return
Codes" https://infosys.beckhoff.com/content/1033/te132x_tc3_bodeplot/374277003.html)."""

from __future__ import annotations

import enum

AMS_TCP_PORT = 48898


class Command(enum.IntEnum):
    INVALID = 0
    READ_DEVICE_INFO = 1
    READ = 2
    WRITE = 3
    READ_STATE = 4
    WRITE_CONTROL = 5
    ADD_NOTIFICATION = 6
    DEL_NOTIFICATION = 7
    NOTIFICATION = 8  # server → client, sent as a request, never answered
    READ_WRITE = 9


class StateFlag(enum.IntFlag):
    RESPONSE = 0x0001
    NO_RETURN = 0x0002
    ADS_COMMAND = 0x0004
    SYSTEM_COMMAND = 0x0008
    HIGH_PRIORITY = 0x0010
    TIMESTAMP = 0x0020
    UDP = 0x0040
    INIT_COMMAND = 0x0080
    BROADCAST = 0x8000


REQUEST_FLAGS = StateFlag.ADS_COMMAND  # 0x0004, also for DeviceNotification (ads.md §1.4)
RESPONSE_FLAGS = StateFlag.ADS_COMMAND | StateFlag.RESPONSE  # 0x0005


class AdsState(enum.IntEnum):
    INVALID = 0
    IDLE = 1
    RESET = 2
    INIT = 3
    START = 4
    RUN = 5
    STOP = 6
    SAVECFG = 7
    LOADCFG = 8
    POWERFAILURE = 9
    POWERGOOD = 10
    ERROR = 11
    SHUTDOWN = 12
    SUSPEND = 13
    RESUME = 14
    CONFIG = 15
    RECONFIG = 16


class TransMode(enum.IntEnum):
    """AdsLib ADSTRANSMODE (pyads' constants call 2 "CLIENT1REQ", wrongly: ads.md §1.5)."""

    NONE = 0
    CLIENT_CYCLE = 1
    CLIENT_ON_CHANGE = 2
    SERVER_CYCLE = 3
    SERVER_ON_CHANGE = 4
    SERVER_CYCLE2 = 5
    SERVER_ON_CHANGE2 = 6
    CLIENT_1REQ = 10


CYCLIC_MODES = frozenset({TransMode.CLIENT_CYCLE, TransMode.SERVER_CYCLE, TransMode.SERVER_CYCLE2})
ON_CHANGE_MODES = frozenset(
    {TransMode.CLIENT_ON_CHANGE, TransMode.SERVER_ON_CHANGE, TransMode.SERVER_ON_CHANGE2}
)


class IndexGroup(enum.IntEnum):
    """Reserved index groups of every ADS device (ads.md §3)."""

    SYM_HNDBYNAME = 0xF003
    SYM_VALBYNAME = 0xF004
    SYM_VALBYHND = 0xF005
    SYM_RELEASEHND = 0xF006
    SYM_INFOBYNAME = 0xF007
    SYM_VERSION = 0xF008
    SYM_INFOBYNAMEEX = 0xF009
    SYM_UPLOAD = 0xF00B
    SYM_UPLOADINFO = 0xF00C
    SYM_DT_UPLOAD = 0xF00E
    SYM_UPLOADINFO2 = 0xF00F
    SYM_DT_INFOBYNAMEEX = 0xF011
    SUMUP_READ = 0xF080
    SUMUP_WRITE = 0xF081
    SUMUP_READWRITE = 0xF082
    SUMUP_READEX = 0xF083
    SUMUP_READEX2 = 0xF084
    SUMUP_ADDDEVNOTE = 0xF085
    SUMUP_DELDEVNOTE = 0xF086
    DEVICE_DATA = 0xF100


SYSTEM_SERVICE_PORT = 10000  # AMSPORT_R3_SYSSERV (Tc2_System T_AmsPort; ads-client SystemService)
SYSTEM_EXTENDED_STATE = 0xF0  # IG 240 on port 10000: ads-client readTcSystemExtendedState


SUM_GROUPS = frozenset(g for g in IndexGroup if 0xF080 <= g <= 0xF086)


class AmsError(enum.IntEnum):
    """Codes in the AMS header error field (routing/transport); the payload is then empty."""

    NOERROR = 0x0
    INTERNAL = 0x1
    TARGET_PORT_NOT_FOUND = 0x6
    TARGET_MACHINE_NOT_FOUND = 0x7
    UNKNOWN_CMD_ID = 0x8
    INVALID_AMS_LENGTH = 0xE
    PORT_ALREADY_IN_USE = 0x506  # router errors (ads.md §2)
    NO_MORE_QUEUES = 0x508


class AmsTcpCommand(enum.IntEnum):
    """The reserved field of the AMS/TCP header: 0 carries an AMS frame, the others talk to the
    router (ads-client `AMS_HEADER_FLAG`; jisotalo/ads-server; ads.md §1.2)."""

    AMS_CMD = 0x0000
    PORT_CLOSE = 0x0001
    PORT_CONNECT = 0x1000
    ROUTER_NOTE = 0x1001
    GET_LOCAL_NETID = 0x1002


class AdsErr(enum.IntEnum):
    """Device errors in the ADS result field of a response payload."""

    NOERROR = 0x000
    DEVICE_ERROR = 0x700
    SRVNOTSUPP = 0x701
    INVALIDGRP = 0x702
    INVALIDOFFSET = 0x703
    INVALIDACCESS = 0x704
    INVALIDSIZE = 0x705
    INVALIDDATA = 0x706
    NOTREADY = 0x707
    BUSY = 0x708
    NOMEMORY = 0x70A  # a reply the server cannot hold (liftd: above max_frame_bytes)
    SYMBOLNOTFOUND = 0x710
    INVALIDSTATE = 0x712
    TRANSMODENOTSUPP = 0x713
    NOTIFYHNDINVALID = 0x714
    NOMOREHDLS = 0x716
    INVALIDWATCHSIZE = 0x717
    ACCESSDENIED = 0x723


class Adst(enum.IntEnum):
    """ADS data type ids of symbol entries (AdsDef.h ADST_*)."""

    VOID = 0
    INT16 = 2
    INT32 = 3
    REAL32 = 4
    REAL64 = 5
    INT8 = 16
    UINT8 = 17
    UINT16 = 18
    UINT32 = 19
    INT64 = 20
    UINT64 = 21
    STRING = 30
    WSTRING = 31
    BIT = 33


class SymbolFlag(enum.IntFlag):
    """ADSSYMBOLFLAG_* of TwinCAT symbol entries."""

    PERSISTENT = 0x0001
    BITVALUE = 0x0002
    REFERENCETO = 0x0004
    TYPEGUID = 0x0008
    TCCOMIFACEPTR = 0x0010
    READONLY = 0x0020
