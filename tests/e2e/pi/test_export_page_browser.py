"""The export page in Chromium: each checkbox sits beside its label (on one line, left of
the text), and the preview shows the first rows of every table as the CSV holds them."""

from __future__ import annotations

import csv
import io
import zipfile
from pathlib import Path
from typing import Any

import pytest
from playwright.sync_api import Page, expect
from sqlalchemy import Engine

from chameleons.backend.db import build_sessionmaker, session_scope
from chameleons.backend.export.columns import TABLE_NAMES
from tests.backend.test_auth import add_user
from tests.e2e.pi.test_dashboard_browser import log_in
from tests.support.factories import PopulatedStudy, populate
from tests.support.live_server import LiveServer

pytestmark = pytest.mark.browser
LABELS = (
    "Parquet",
    "Excel workbook (times as date-times, in UTC)",
    "JSON",
    "SPSS (.sav)",
    "Stata (.dta)",
    "Include rehearsal sessions",
)


@pytest.fixture
def study(engine: Engine, settings: Any) -> PopulatedStudy:
    with session_scope(build_sessionmaker(engine)) as db:
        data = populate(db, 7, rehearsals=1)
    add_user(engine, "pia", "correct horse", "pi")
    return data


def test_each_checkbox_is_beside_its_label(
    live_server: LiveServer, page: Page, study: PopulatedStudy
) -> None:
    page.set_viewport_size({"width": 1280, "height": 800})
    log_in(page, live_server, f"/pi/export?study={study.study_id}")
    for text in LABELS:
        box = page.get_by_label(text, exact=True)
        expect(box).to_be_visible()
        label = page.locator("label.check", has_text=text)
        box_area, label_area = box.bounding_box(), label.bounding_box()
        assert box_area is not None
        assert label_area is not None
        # The label's text starts right of the box, on the same line (the box is centred
        # in the label's height, which is one line, not two).
        assert box_area["width"] < 40, text
        assert label_area["height"] < 2.2 * box_area["height"] + 8, text
        middle = box_area["y"] + box_area["height"] / 2
        assert label_area["y"] <= middle <= label_area["y"] + label_area["height"], text
        text_left = label.evaluate(
            "node => { const r = document.createRange(); r.selectNodeContents(node);"
            " const rects = [...r.getClientRects()].filter(x => x.width > 0 && x.left > "
            " node.querySelector('input').getBoundingClientRect().right - 1);"
            " return rects.length ? rects[0].left : -1; }"
        )
        assert box_area["x"] + box_area["width"] <= text_left <= box_area["x"] + 60, text


def test_the_preview_shows_the_first_rows_of_every_table(
    live_server: LiveServer, page: Page, study: PopulatedStudy
) -> None:
    log_in(page, live_server, f"/pi/export?study={study.study_id}")
    preview = page.locator("#export-preview")
    expect(preview.get_by_role("heading", name="Preview")).to_be_visible()
    for name in TABLE_NAMES:
        table = preview.locator(f'.preview-table[data-table="{name}"]')
        expect(table.get_by_role("heading", name=f"{name}.csv")).to_be_visible()
        expect(table.locator("tbody tr")).to_have_count(5)
    # The same cells as the download's first rows.
    with page.expect_download() as download_info:
        page.get_by_role("button", name="Download zip").click()
    bundle = zipfile.ZipFile(io.BytesIO(Path(download_info.value.path()).read_bytes()))
    for name in ("participants", "scores"):
        rows = list(csv.reader(io.StringIO(bundle.read(f"{name}.csv").decode())))
        table = preview.locator(f'.preview-table[data-table="{name}"] table')
        header = table.locator("thead th").all_inner_texts()
        assert header == rows[0]
        first = table.locator("tbody tr").first.locator("td").all_text_contents()
        assert first == rows[1]
