"""The entry's settings, read from the environment, with their defaults and refusals."""

import pytest

from warehouse_phys.lorr.startkit import settings


def test_every_setting_has_its_default():
    assert settings.setting("WAREHOUSE_PHYS_PLANNER") == "guided-ops-repair"
    assert settings.round_share() == settings.ROUND_SHARE
    with pytest.raises(KeyError):
        settings.setting("WAREHOUSE_PHYS_NO_SUCH_SETTING")


def test_the_guidance_setting_is_a_json_object_of_fields(monkeypatch):
    assert settings.entry_guidance() == {}
    monkeypatch.setenv("WAREHOUSE_PHYS_GUIDANCE", '{"reroute": 32}')
    assert settings.entry_guidance() == {"reroute": 32}
    for text in ("[1]", "{", "32"):
        monkeypatch.setenv("WAREHOUSE_PHYS_GUIDANCE", text)
        with pytest.raises(ValueError, match="not a JSON object of the planner's fields"):
            settings.entry_guidance()


def test_the_round_share_is_a_share_above_zero_or_none(monkeypatch):
    assert settings.round_share() == settings.ROUND_SHARE
    for text, share in (("0.25", 0.25), ("2", 2.0), ("none", None), (" None ", None)):
        monkeypatch.setenv("WAREHOUSE_PHYS_ROUND_SHARE", text)
        assert settings.round_share() == share
    for text in ("0", "-1", "nan", "inf", "", "half"):
        monkeypatch.setenv("WAREHOUSE_PHYS_ROUND_SHARE", text)
        with pytest.raises(ValueError, match=f"WAREHOUSE_PHYS_ROUND_SHARE={text}: a share"):
            settings.round_share()
