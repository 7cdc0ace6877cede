"""The PI's session page shows the imported instrument streams under the timeline, each
plotted over the session's time; only a PI sees them."""

from __future__ import annotations

from pathlib import Path
from typing import Any

import pytest
from fastapi.testclient import TestClient
from sqlalchemy import Engine

from chameleons.backend.db import build_sessionmaker, session_scope
from chameleons.backend.instruments.xdf_import import import_xdf
from tests.backend.test_auth import add_user, login
from tests.instruments.xdf_session import recorded_session


@pytest.mark.slow
def test_the_session_page_plots_the_streams_under_the_timeline(
    client: TestClient, engine: Engine, settings: Any, tmp_path: Path
) -> None:
    with session_scope(build_sessionmaker(engine)) as db:
        recorded = recorded_session(db, tmp_path)
        result = import_xdf(db, recorded.session_id, recorded.path, Path(settings.data_dir))
        ids = {row.name: row.id for row in result.streams}
    url = f"/pi/sessions/{recorded.session_id}"
    plot = f"{url}/instruments/{ids['BioSemi']}.svg"
    assert client.get(plot, follow_redirects=False).status_code in (303, 401, 403)
    add_user(engine, "pia", "correct horse", "pi")
    login(client, "pia", "correct horse")
    page = client.get(url)
    assert page.status_code == 200
    _timeline, below = page.text.split('id="timeline"', 1)[1].split('id="instruments"', 1)
    assert "<h3>Other instruments</h3>" in below
    assert "BioSemi · EMG · 2 channels" in below
    assert f'src="{plot}"' in below
    assert f'src="{url}/instruments/{ids["PsychoPy"]}.svg"' in below
    image = client.get(plot)
    assert image.status_code == 200
    assert image.headers["content-type"] == "image/svg+xml"
    assert "zygomaticus" in image.text
    markers = client.get(f"{url}/instruments/{ids['PsychoPy']}.svg")
    assert "stimulus_on" in markers.text
    assert client.get(f"{url}/instruments/9999.svg").status_code == 404
    assert client.get(f"/pi/sessions/9999/instruments/{ids['BioSemi']}.svg").status_code == 404
