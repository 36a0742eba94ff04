"""Python key builders give exactly the keys of schemas/src/keys.rs (keys.json is
written by the Rust golden test)."""

import json
from pathlib import Path

import pytest

from wearnav_schemas import COMMAND_VERBS, KeyNameError, Keys, command_verb

KEYS_JSON = Path(__file__).resolve().parents[2] / "vectors" / "keys.json"


def test_every_key_builder_matches_rust():
    golden = json.loads(KEYS_JSON.read_text())
    keys = Keys(golden["user"])
    for case in golden["cases"]:
        got = getattr(keys, case["method"])(*case["args"])
        assert got == case["key"], case


def test_command_verbs_match_rust():
    golden = json.loads(KEYS_JSON.read_text())
    assert dict(golden["command_verbs"]) == COMMAND_VERBS
    assert command_verb({"Destination": {"label": "x"}}) == "destination"
    assert command_verb("WhereAmI") == "where-am-i"


@pytest.mark.parametrize("user", ["", "al/ice", "a*", "bob smith", "ä"])
def test_user_names_that_cannot_be_a_key_chunk_are_refused(user):
    with pytest.raises(KeyNameError):
        Keys(user)


def test_refusal_names_the_offending_character():
    with pytest.raises(KeyNameError, match="'/'"):
        Keys("al/ice")
    assert Keys("bob-2.test_x").hazard() == "wearnav/bob-2.test_x/perception/hazard"
