"""GlobalArchive tables: every numeric cell is a number or empty (unknown), never the text "nan"/"inf";
a mandatory number that is not finite is refused by name."""

import csv
import io
import math

import pytest

from usvips.core.campaign import Campaign
from usvips.core.deployment import Deployment
from usvips.core.errors import InvalidParameterError
from usvips.io.globalarchive import count_table, length_table, metadata_csv

CAMPAIGN = Campaign("2024-03_Reef_stereo-BRUVs", "Reef", "stereo-BRUVs", "random", "Ana Ng")


def _rows(text: str) -> list[dict]:
    return list(csv.DictReader(io.StringIO(text), dialect="excel-tab"))


@pytest.mark.parametrize("sigma", [math.nan, math.inf, -math.inf])
def test_an_unknown_precision_is_an_empty_cell_not_nan(sigma):
    text = length_table(CAMPAIGN, [("BRUV1", "Labridae", "Choerodon", "rubescens", "C1", 1, 0.412, sigma, "7"),
                                   ("BRUV1", "Labridae", "Choerodon", "rubescens", "C1", 1, 0.3, 0.002, "8")])
    rows = _rows(text)
    assert rows[0]["Precision"] == "" and float(rows[0]["Length"]) == pytest.approx(412.0)
    assert float(rows[1]["Precision"]) == pytest.approx(2.0)
    assert "nan" not in text.lower() and "inf" not in text.lower()


@pytest.mark.parametrize("length", [math.nan, math.inf])
def test_a_length_that_is_not_a_number_is_refused_naming_its_object(length):
    with pytest.raises(InvalidParameterError, match=r"object 7: its Length .*GlobalArchive Length"):
        length_table(CAMPAIGN, [("BRUV1", "Labridae", "Choerodon", "rubescens", "", 1, length, 0.002, "7")])


def test_count_and_metadata_numbers_are_finite_or_empty():
    deployment = Deployment("BRUV1", date="2024-03-02", time="10:20", latitude=-32.1, longitude=115.2)
    text = metadata_csv(CAMPAIGN, [(deployment, "")]) + count_table(CAMPAIGN, {("BRUV1", "", "", ""): 3})
    assert "nan" not in text.lower()
    row = next(csv.DictReader(io.StringIO(metadata_csv(CAMPAIGN, [(deployment, "")]))))
    assert row["Depth"] == "" and float(row["Latitude"]) == -32.1
