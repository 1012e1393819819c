"""The campaign record (GlobalArchive's CampaignID, Project, method …): validated field by field, named."""

import pytest

from usvips.core.campaign import CAMPAIGN_FIELDS, MANDATORY, Campaign
from usvips.core.errors import InvalidParameterError


def test_a_campaign_round_trips_through_its_dict_and_names_what_an_export_needs():
    campaign = Campaign("2024-03_Abrolhos_stereo-BRUVs", " Abrolhos ", "stereo-BRUVs", "stratified", "Ana", "UWA",
                        "2024-03-01", "2024-03-01")
    assert campaign.project == "Abrolhos"  # trimmed
    assert Campaign.from_dict(campaign.to_dict()) == campaign and tuple(campaign.to_dict()) == CAMPAIGN_FIELDS
    assert campaign.missing() == []
    assert Campaign().missing() == list(MANDATORY)
    assert Campaign(campaign_id="x", method="UVC").missing() == ["project", "submitter"]


@pytest.mark.parametrize(("values", "name"), [
    ({"campaign_id": "2024/03 reef"}, "campaign_id"), ({"campaign_id": "../x"}, "campaign_id"),
    ({"campaign_id": "2024-13_Reef_stereo-BRUVs"}, "campaign_id"), ({"campaign_id": "2024-00_Reef_M"}, "campaign_id"),
    ({"project": "two\tcolumns"}, "project"), ({"comment": "line\nbreak"}, "comment"),
    ({"start_date": "2024-3-1"}, "start_date"), ({"end_date": "tomorrow"}, "end_date"),
    ({"start_date": "2024-03-05", "end_date": "2024-03-01"}, "end_date")])
def test_bad_values_are_named(values, name):
    with pytest.raises(InvalidParameterError, match=f"parameter {name}:"):
        Campaign(**values)


def test_a_stored_dict_with_unknown_fields_is_refused_by_name():
    with pytest.raises(InvalidParameterError, match="unknown field.*colour"):
        Campaign.from_dict({"campaign_id": "x", "colour": "blue"})
    with pytest.raises(InvalidParameterError, match="mapping"):
        Campaign.from_dict(["x"])
