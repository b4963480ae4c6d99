"""Repairs the robot remembers: how the operator answered each failure, suggested when the same failure comes again.

A help request names the node that failed and the reason. The /change_tree requests the operator makes until the
tree resumes (undone ones left out) are that failure's repair. When a help request with the same node and reason
comes again, in this session or a later one (the memory is saved in the data directory), it carries the remembered
requests as a suggestion, and the /change_tree operation ``repair`` applies them as one edit (one undo reverts them
all). The latest repair of a failure replaces the one before. Reasons are compared with their measured values
left out ("waited 1.1 s", "15.2 cm from gap_2": the same failure as "waited 1.0 s", "14.8 cm from gap_2").
"""

import re
import typing

from teleteach.bt.editor import OPERATIONS, EditRequest

Failure = typing.Tuple[str, str]  # (node name, reason)
_MEASURED = re.compile(r"[-+]?\d+\.\d+")  # decimals are measurements; whole numbers may be names (product_pick_1)


def failure_key(node_name: str, reason: str) -> Failure:
    """What makes two failures the same: the node, and the reason without its measured values."""
    return node_name, _MEASURED.sub("#", reason)


class RepairError(ValueError):
    """A saved repair memory is malformed; the message names the file and the entry."""


class RepairMemory:
    """Failures and the requests that repaired them, in the order they were first remembered."""

    def __init__(self, repairs: typing.Optional[typing.Dict[Failure, typing.Tuple[EditRequest, ...]]] = None):
        self._repairs: typing.Dict[Failure, typing.Tuple[Failure, typing.Tuple[EditRequest, ...]]] = {}
        for (node_name, reason), requests in (repairs or {}).items():
            self.remember(node_name, reason, requests)

    def __len__(self) -> int:
        return len(self._repairs)

    def suggestion(self, node_name: str, reason: str) -> typing.Tuple[EditRequest, ...]:
        """The remembered repair of this failure (empty if none)."""
        return self._repairs.get(failure_key(node_name, reason), ((), ()))[1]

    def remember(self, node_name: str, reason: str, requests: typing.Sequence[EditRequest]) -> bool:
        """Keep ``requests`` as the repair of this failure; return whether the memory changed."""
        requests = tuple(requests)
        if not requests or self.suggestion(node_name, reason) == requests:
            return False
        self._repairs[failure_key(node_name, reason)] = ((node_name, reason), requests)
        return True

    def to_dict(self) -> typing.Dict[str, typing.Any]:
        """Plain data for yaml."""
        return {
            "repairs": [
                {"node": node, "reason": reason, "edits": [request._asdict() for request in requests]}
                for (node, reason), requests in self._repairs.values()
            ]
        }

    @classmethod
    def from_dict(cls, data: typing.Any, source: str = "repair memory") -> "RepairMemory":
        """Build from plain data (``to_dict``'s format); raise :class:`RepairError` naming what is wrong."""
        if not isinstance(data, dict) or not isinstance(data.get("repairs"), list):
            raise RepairError(f"{source}: expected a mapping with a 'repairs' list")
        repairs: typing.Dict[Failure, typing.Tuple[EditRequest, ...]] = {}
        for number, entry in enumerate(data["repairs"], start=1):
            where = f"{source}: repair {number}"
            if not isinstance(entry, dict) or not isinstance(entry.get("edits"), list):
                raise RepairError(f"{where}: expected node, reason and a list of edits")
            node, reason = entry.get("node"), entry.get("reason")
            if not isinstance(node, str) or not isinstance(reason, str):
                raise RepairError(f"{where}: node and reason must be strings")
            repairs[(node, reason)] = tuple(edit_request(edit, where) for edit in entry["edits"])
        return cls(repairs)


def edit_request(data: typing.Any, where: str) -> EditRequest:
    """An edit saved as a mapping of EditRequest's fields; :class:`RepairError` naming ``where`` when it is not one."""
    fields = EditRequest._fields
    if not isinstance(data, dict) or set(data) - set(fields) or data.get("operation") not in OPERATIONS:
        raise RepairError(f"{where}: an edit is a mapping of {', '.join(fields)} with a known operation, got {data!r}")
    try:
        request = EditRequest(**data)
        return request._replace(index=int(request.index), parameter=float(request.parameter))
    except (TypeError, ValueError) as error:
        raise RepairError(f"{where}: {data!r}: {error}") from None
