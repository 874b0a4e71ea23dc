"""Helpers the workbench tests share."""
import re

import pytest

from workbench.cases import build_model, load_case
from workbench.errors import InputError


def assert_case_refused(p, pattern: str) -> None:
    """The case file `p` is refused as it is built, in one line that starts
    with its path and matches `pattern`."""
    with pytest.raises(InputError) as err:
        build_model(load_case(p))
    msg = str(err.value)
    assert "\n" not in msg and msg.startswith(str(p)), msg
    assert re.search(pattern, msg), msg
