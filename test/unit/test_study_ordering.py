"""Counterbalancing: balanced Latin squares, each participant's session plan, seeded random orders."""

import collections
import itertools
import pathlib

import pytest

from teleteach.study.ordering import (
    QUESTIONNAIRE,
    TRIAL,
    ParticipantError,
    balanced_latin_square,
    participant_number,
    session_plan,
)
from teleteach.study.schema import load_study, parse_study

ROOT = pathlib.Path(__file__).resolve().parents[2]
EXAMPLE = ROOT / "config" / "studies" / "example.yaml"


@pytest.mark.parametrize("count", [1, 2, 3, 4, 5, 6])
def test_a_balanced_latin_square_is_latin_and_balances_first_order_carryover(count):
    rows = balanced_latin_square(count)
    assert len(rows) == (count if count % 2 == 0 else 2 * count)
    for row in rows:
        assert sorted(row) == list(range(count))
    # Expect every treatment equally often in every position
    for position in range(count):
        assert collections.Counter(row[position] for row in rows) == {
            value: len(rows) // count for value in range(count)
        }
    # Expect every ordered pair of neighbours equally often (Williams design)
    pairs = collections.Counter(pair for row in rows for pair in zip(row, row[1:]))
    if count > 1:
        assert set(pairs) == set(itertools.permutations(range(count), 2))
        assert len(set(pairs.values())) == 1


def test_each_participant_gets_the_conditions_in_blocks_followed_by_the_questionnaire():
    study = load_study(EXAMPLE)
    first, second = session_plan(study, "P01"), session_plan(study, "P02")
    assert [step.key for step in first] == [
        "01_guided_remove_place_item_1",
        "02_guided_remove_place_item_2",
        "03_guided_stiffen_y_1",
        "04_guided_stiffen_y_2",
        "05_guided_questionnaire",
        "06_unguided_remove_place_item_1",
        "07_unguided_remove_place_item_2",
        "08_unguided_stiffen_y_1",
        "09_unguided_stiffen_y_2",
        "10_unguided_questionnaire",
    ]
    # Expect the second participant to start with the other condition (the Latin square's second row)
    assert [step.condition for step in second if step.kind == QUESTIONNAIRE] == ["unguided", "guided"]
    assert [step.trial for step in first if step.kind == TRIAL] == list(range(1, 9))
    assert session_plan(study, "P03") == first  # two rows: the third participant is the first one's order again


def test_random_orders_are_seeded_per_participant(tmp_path):
    text = EXAMPLE.read_text().replace(
        "conditions: latin_square\n  tasks: fixed", "conditions: random\n  tasks: random"
    )
    path = tmp_path / "random.yaml"
    path.write_text(text.replace("script: scripts/", f"script: {EXAMPLE.parent}/scripts/"))
    study = parse_study(path.read_text(), path)
    orders = {tuple(step.key for step in session_plan(study, f"P{number:02d}")) for number in range(1, 21)}
    assert session_plan(study, "P05") == session_plan(study, "P05")
    # Expect both condition orders and different task orders among 20 participants
    assert len({order[0].split("_")[1] for order in orders}) == 2
    assert len(orders) > 2


def test_a_participant_needs_a_number_or_a_place_in_the_study_s_list(tmp_path):
    study = load_study(EXAMPLE)
    assert participant_number(study, "P07") == 7
    assert participant_number(study, "pilot-12") == 12
    with pytest.raises(ParticipantError, match="has no number >= 1"):
        participant_number(study, "alice")
    path = tmp_path / "listed.yaml"
    path.write_text(
        "participants: [alice, bob]\nconditions: {a: {}, b: {}}\ntasks: {t: {goal: {tree: {absent: [PlaceItem]}}}}\n"
    )
    listed = parse_study(path.read_text(), path)
    assert participant_number(listed, "bob") == 2
    assert [step.condition for step in session_plan(listed, "bob")] == ["b", "b", "a", "a"]
    with pytest.raises(ParticipantError, match=r"'carol' is not in the study's participants \(alice, bob\)"):
        participant_number(listed, "carol")
