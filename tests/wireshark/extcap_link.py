"""Where tests find modtap-extcap: Wireshark 4.0 looks for extcaps only in its global folder
(and ignores WIRESHARK_EXTCAP_DIR when run as root), so a test links the build's program there
for its duration, unless an installed one is already there."""
import os

GLOBAL_EXTCAP = "/usr/lib/x86_64-linux-gnu/wireshark/extcap"


def link_extcap(extcap):
    """Returns (linked, cleanup): linked when Wireshark will run the build's `extcap`."""
    target = os.path.join(GLOBAL_EXTCAP, "modtap-extcap")
    if os.path.lexists(target):
        return os.path.realpath(target) == os.path.realpath(extcap), lambda: None
    try:
        os.symlink(os.path.realpath(extcap), target)
    except OSError:
        return False, lambda: None
    return True, lambda: os.unlink(target)


def preference_prefix(port):
    """The capture options' preference names for a port: extcap.modtap__dev_pts_3.baud."""
    return "extcap.modtap_" + "".join(c if c.isalnum() else "_" for c in port.lower())
