"""A <Part>Config built from its yaml or the parameter server (teleteach.core.parameters): every value from the
mapping, the yaml's spellings made the field's types, and a missing or unknown key named in one line, nested ones with
their section."""

import dataclasses
from typing import Dict, List, Optional, Tuple

import pytest

from teleteach.core.parameters import from_mapping, key_problems


@dataclasses.dataclass(frozen=True)
class Filter:
    cutoff: float
    order: int

    def __post_init__(self):
        if self.cutoff <= 0.0:
            raise ValueError(f"cutoff must be > 0 Hz, got {self.cutoff}")


@dataclasses.dataclass(frozen=True)
class Device:
    name: str
    rate: float
    axes: Tuple[str, ...]
    bounds: tuple
    enabled: bool
    filter: Filter
    labels: Dict[str, str]
    samples: List[float]
    cache: Optional[str] = None


class DeviceError(ValueError):
    """A bad device parameter."""


VALUES = {
    "name": "sigma7",
    "rate": 1000,
    "axes": ["x", "y"],
    "bounds": [0.1, 0.2],
    "enabled": True,
    "filter": {"cutoff": 20, "order": 2},
    "labels": {"x": "right"},
    "samples": [1.0, 2.0],
}


def test_every_value_comes_from_the_mapping_in_the_field_s_type():
    device = from_mapping(Device, VALUES, "device", optional=("cache",))
    assert device == Device("sigma7", 1000.0, ("x", "y"), (0.1, 0.2), True, Filter(20.0, 2), {"x": "right"}, [1.0, 2.0])
    # Expect a mapping that is not a dataclass's, a list that is not a tuple's, a section already built, as given
    assert isinstance(device.labels, dict) and isinstance(device.samples, list)
    built = from_mapping(Device, dict(VALUES, filter=Filter(5.0, 1)), "device", optional=("cache",))
    assert built.filter == Filter(5.0, 1)
    assert isinstance(device.rate, float) and isinstance(device.filter.cutoff, float)
    assert isinstance(device.filter.order, int) and device.enabled is True
    # Expect a yes that is not a bool, or a number that is text, to reach the dataclass as given (its checks decide)
    assert from_mapping(Device, dict(VALUES, enabled=1, name=7), "device", optional=("cache",)).enabled == 1
    assert from_mapping(Device, dict(VALUES, cache="/tmp/c"), "device").cache == "/tmp/c"


def test_missing_and_unknown_keys_are_named_in_one_line_nested_ones_with_their_section():
    values = dict(VALUES, colour="red", size=3, filter={"cutoff": 20.0, "width": 3})
    del values["rate"], values["axes"]
    expected = r"^device: missing rate, axes, cache; unknown colour, size; missing filter/order; unknown filter/width$"
    with pytest.raises(DeviceError, match=expected):
        from_mapping(Device, values, "device", DeviceError)
    assert key_problems(Device, VALUES, optional=("cache",)) == ""
    assert key_problems(Device, VALUES) == "missing cache"  # a field with a default is no exception unless named


def test_a_value_the_dataclass_refuses_is_the_error_of_the_caller_with_where_it_was():
    with pytest.raises(DeviceError, match=r"^device/filter: cutoff must be > 0 Hz, got -1.0$"):
        from_mapping(Device, dict(VALUES, filter={"cutoff": -1, "order": 2}), "device", DeviceError, ("cache",))
    with pytest.raises(DeviceError, match=r"^device/filter: '<=' not supported between instances of 'str'"):
        from_mapping(Device, dict(VALUES, filter={"cutoff": "fast", "order": 2}), "device", DeviceError, ("cache",))


def test_the_caller_s_own_error_passes_unchanged():
    @dataclasses.dataclass(frozen=True)
    class Checked:
        rate: float

        def __post_init__(self):
            if self.rate > 100.0:
                raise DeviceError("rate above 100 Hz")

    with pytest.raises(DeviceError, match=r"^rate above 100 Hz$"):
        from_mapping(Checked, {"rate": 1000}, "checked", DeviceError)
