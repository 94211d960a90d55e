"""Test-session settings. Ray (the sweep and RLlib tests) runs on the loopback interface only:
its single-machine mode, which Ray reads when it is first imported (any test module may import
it first), and which the processes the tests start inherit."""

import os

os.environ.setdefault("RAY_ENABLE_WINDOWS_OR_OSX_CLUSTER", "0")
