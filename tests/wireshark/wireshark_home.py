"""Wireshark as a user runs it with modtap's plugin: a home whose personal plugin folder holds
the build's plugin (and whose profiles folder the modtap profile), and the program run in it.

Wireshark loads no personal plugin for root (wsutil's started_with_special_privs counts root as
privileged), and the tests run as root on a fresh machine: there each program runs as nobody.
"""
import os
import shutil

PROFILE = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "..", "plugins",
                       "wireshark", "profile")


def make_home(work, plugin):
    """A home in `work` with the plugin (the build's plugins/wireshark/RELEASE/epan/modtap.so)
    where Wireshark RELEASE looks for a user's plugins, and the modtap profile."""
    home = os.path.join(work, "home")
    shutil.rmtree(home, ignore_errors=True)
    release = os.path.basename(os.path.dirname(os.path.dirname(os.path.abspath(plugin))))
    plugins = os.path.join(home, ".local", "lib", "wireshark", "plugins", release, "epan")
    os.makedirs(plugins)
    shutil.copy(plugin, plugins)
    shutil.copytree(PROFILE, os.path.join(home, ".config", "wireshark", "profiles", "modtap"))
    if os.geteuid() == 0:  # nobody's home: Wireshark writes its recent files there
        for folder, _, files in os.walk(home):
            for name in [folder] + [os.path.join(folder, f) for f in files]:
                shutil.chown(name, "nobody", "nogroup")
    return home


def as_user(args, home):
    """The command line that runs `args` in `home`, as nobody where the tests run as root."""
    user = ["setpriv", "--reuid=nobody", "--regid=nogroup", "--clear-groups"] \
        if os.geteuid() == 0 else []
    return user + ["env", f"HOME={home}"] + args
