"""``gateway.pytest_plugin``: the pytest plugin under its earlier name (it lives in
gateway/ci/pytest_plugin.py). The same module object, so ``-p gateway.pytest_plugin`` and the
``cornet`` entry point register one plugin, and ``from gateway.pytest_plugin import reached``
keeps working."""

import sys

from gateway.ci import pytest_plugin as _plugin

sys.modules[__name__] = _plugin
