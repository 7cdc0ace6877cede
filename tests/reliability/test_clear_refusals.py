"""Input no route can store or look up gets a 4xx with a sentence, on SQLite and PostgreSQL,
never a 500: a NUL character in free text, in an address or a media path; whole numbers
>= 2**63 in paths, queries and bodies; NaN and Infinity in JSON bodies; and the withdraw
form's paths. Nothing is stored by a refused request."""

from __future__ import annotations

import pytest
from fastapi.testclient import TestClient
from starlette.websockets import WebSocketDisconnect

from chameleons.backend.input_guard import (
    MAX_JSON_DEPTH,
    MAX_ROW_ID,
    NOT_FINITE,
    NOT_UNICODE,
    NUL_IN_ADDRESS,
    NUL_IN_TEXT,
    TOO_DEEP,
    TOO_LARGE,
    TOO_LARGE_IN_ADDRESS,
    TOO_LARGE_NUMBER,
)
from chameleons.i18n import gettext
from tests.backend.sessions.conftest import phone, pi, study_id, wizard
from tests.support.bots import ParticipantBot, StaffApi, WizardBot

__all__ = ["phone", "pi", "study_id", "wizard"]

HUGE = 2**63
HEADERS = {"Content-Type": "application/json"}


def _post_raw(client: TestClient, path: str, raw: str, csrf: str = "") -> tuple[int, object]:
    headers = {**HEADERS, **({"X-CSRF-Token": csrf} if csrf else {})}
    response = client.post(path, content=raw.encode(), headers=headers)
    return response.status_code, response.json().get("detail")


def _answered(phone: ParticipantBot, wizard: WizardBot) -> int:
    events = wizard.staff.get(f"/api/sessions/{wizard.session_id}/events?limit=5000")
    return sum(1 for e in events if str(e["kind"]).startswith(("questionnaire", "consent")))


def test_a_nul_in_the_phones_free_text_is_a_422_with_a_sentence_and_nothing_is_stored(
    client: TestClient, wizard: WizardBot, phone: ParticipantBot
) -> None:
    before = _answered(phone, wizard)
    raw = (
        '{"client_id": "abcdefgh12345678", "position": -1, "questionnaire": "about_you",'
        ' "answers": {"comment": "hello\\u0000world"}}'
    )
    status, detail = _post_raw(client, f"/api/phone/{wizard.token}/questionnaire", raw)
    assert status == 422
    assert detail == NUL_IN_TEXT
    # A NUL in a key is refused the same way; so is one in the consent's client id.
    raw_key = raw.replace('"comment"', '"com\\u0000ment"').replace("hello\\u0000world", "hi")
    assert _post_raw(client, f"/api/phone/{wizard.token}/questionnaire", raw_key)[0] == 422
    assert _answered(phone, wizard) == before


def test_a_nul_in_staff_free_text_is_a_422(
    client: TestClient, pi: StaffApi, wizard: WizardBot
) -> None:
    status, detail = _post_raw(
        client, f"/api/sessions/{wizard.session_id}/notes", '{"text": "a\\u0000b"}', pi.csrf
    )
    assert (status, detail) == (422, NUL_IN_TEXT)
    notes = pi.get(f"/api/sessions/{wizard.session_id}/events")
    assert not [e for e in notes if e["kind"] == "wizard.note"]
    form = client.post(
        "/pi/participants/P001/exclude",
        data={"reason": "bad\x00reason", "csrf_token": pi.csrf},
        headers={"X-CSRF-Token": pi.csrf},
    )
    assert form.status_code == 422
    assert form.json()["detail"] == NUL_IN_TEXT


@pytest.mark.parametrize("constant", ["NaN", "Infinity", "-Infinity"])
def test_nan_and_infinity_in_a_json_body_are_a_422(
    client: TestClient, pi: StaffApi, wizard: WizardBot, constant: str
) -> None:
    raw = f'{{"kind": "worker.note", "payload": {{"x": {constant}}}, "worker_time": {constant}}}'
    status, detail = _post_raw(client, f"/api/sessions/{wizard.session_id}/events", raw, pi.csrf)
    assert (status, detail) == (422, NOT_FINITE)


@pytest.mark.parametrize("number", ["1e400", "-1e400", "1.5e309", "123456789e999"])
def test_a_number_beyond_what_a_float_holds_is_a_422_not_infinity(
    client: TestClient, wizard: WizardBot, phone: ParticipantBot, number: str
) -> None:
    """Python's JSON parser turns 1e400 into infinity: it reached validation, whose error
    (quoting the input) could not be written as JSON, and the phone got a 500."""
    before = _answered(phone, wizard)
    raw = (f'{{"client_id": "abcdefgh12345678", "position": {number},'
           ' "questionnaire": "about_you", "answers": {}}')  # fmt: skip
    status, detail = _post_raw(client, f"/api/phone/{wizard.token}/questionnaire", raw)
    assert (status, detail) == (422, TOO_LARGE_NUMBER)
    assert _answered(phone, wizard) == before
    # A large number that fits is an ordinary validation error of its field.
    raw = raw.replace(number, "1e300")
    assert _post_raw(client, f"/api/phone/{wizard.token}/questionnaire", raw)[0] == 422


@pytest.mark.parametrize("depth", [MAX_JSON_DEPTH + 1, 1000, 50_000])
def test_a_json_body_nested_too_deeply_is_a_422_with_a_sentence(
    client: TestClient, pi: StaffApi, wizard: WizardBot, depth: int
) -> None:
    """50,000 nested lists made Python's JSON parser raise RecursionError: a 500."""
    nested = "[" * depth + "]" * depth
    raw = f'{{"kind": "worker.note", "payload": {{"x": {nested}}}}}'
    status, detail = _post_raw(client, f"/api/sessions/{wizard.session_id}/events", raw, pi.csrf)
    assert (status, detail) == (422, TOO_DEEP)
    assert _post_raw(client, f"/api/phone/{wizard.token}/questionnaire", nested)[:2] == (
        422, TOO_DEEP
    )  # fmt: skip
    # Objects nest the same way; a body within the limit is the route's to judge.
    objects = '{"a":' * depth + "1" + "}" * depth
    assert _post_raw(client, f"/api/phone/{wizard.token}/questionnaire", objects)[0] == 422
    within = "[" * (MAX_JSON_DEPTH - 3) + "]" * (MAX_JSON_DEPTH - 3)
    raw = f'{{"kind": "worker.note", "payload": {{"x": {within}}}}}'
    assert _post_raw(client, f"/api/sessions/{wizard.session_id}/events", raw, pi.csrf)[0] == 201


@pytest.mark.parametrize(
    "path",
    [
        f"/api/sessions/{HUGE}",
        f"/api/sessions/{MAX_ROW_ID + 1}",
        f"/api/sessions/{HUGE * 10}/events",
        f"/api/sessions/-{HUGE + 1}",
        f"/api/studies/{HUGE}",
        f"/pi/sessions/{HUGE}",
        f"/pi/recordings/{HUGE}",
        f"/wizard/sessions/{HUGE}",
        f"/pi/sessions/1/instruments/{HUGE}.svg",  # an id with a file extension
        f"/pi/interactions/{MAX_ROW_ID + 1}/synchrony.svg",
    ],
)
def test_ids_beyond_64_bits_in_a_path_are_a_404(
    client: TestClient, pi: StaffApi, path: str
) -> None:
    response = client.get(path)
    assert response.status_code == 404, response.text


def test_ids_beyond_64_bits_in_a_query_or_body_are_a_422(
    client: TestClient, pi: StaffApi, study_id: int
) -> None:
    for query in (f"/pi?study={HUGE}", f"/pi?study={MAX_ROW_ID + 1}"):
        response = client.get(query)
        assert (response.status_code, response.json()["detail"]) == (422, TOO_LARGE_IN_ADDRESS)
    raw = f'{{"study_id": {HUGE}, "booth": "booth-1"}}'
    assert _post_raw(client, "/api/sessions", raw, pi.csrf) == (422, TOO_LARGE)
    # An id beyond PostgreSQL's INTEGER in a body is refused by its field's bound.
    raw = f'{{"study_id": {MAX_ROW_ID + 1}, "booth": "booth-1"}}'
    assert _post_raw(client, "/api/sessions", raw, pi.csrf)[0] == 422
    # The largest id that fits is an ordinary "not found".
    assert client.get(f"/api/sessions/{MAX_ROW_ID}").status_code == 404
    assert client.get(f"/pi/sessions/{MAX_ROW_ID}").status_code == 404


def test_a_device_id_of_decimal_digits_is_text_not_a_number_too_large(
    client: TestClient, wizard: WizardBot
) -> None:
    """The phone's device id is 32 random hex digits; now and then they are all decimal."""
    device = "9" * 32
    with client.websocket_connect(f"/ws/p/{wizard.token}?device={device}") as socket:
        assert socket.receive_json()["type"] == "state"
    # A number where the app reads one is still range-checked.
    response = client.get(f"/pi?study={device}")
    assert (response.status_code, response.json()["detail"]) == (422, TOO_LARGE_IN_ADDRESS)


@pytest.mark.parametrize(
    "path",
    [
        "/media/prompts/m1/audio/x%00.mp3",
        "/media/prompts/m1%00/x.mp3",
        "/media/typed/0123abcd%00.wav",
        "/static/css/app.css%00.js",
        "/p/abc%00def",
    ],
    ids=["prompt-file", "prompt-dir", "typed", "static", "phone"],
)
def test_a_nul_in_a_media_or_page_path_is_a_400(
    client: TestClient, pi: StaffApi, path: str
) -> None:
    # As a logged-in PI, so no login redirect could answer first.
    response = client.get(path)
    assert (response.status_code, response.json()["detail"]) == (400, NUL_IN_ADDRESS)


def test_the_withdraw_form_paths_answer_4xx(
    client: TestClient, pi: StaffApi, study_id: int
) -> None:
    form = {"confirm": "P999", "csrf_token": pi.csrf}
    headers = {"X-CSRF-Token": pi.csrf}
    for code in ("P999", "x" * 500, "%2e%2e", "P001%00"):
        assert client.get(f"/pi/participants/{code}/withdraw").status_code in (400, 404)
        answer = client.post(f"/pi/participants/{code}/withdraw", data=form, headers=headers)
        assert answer.status_code in (400, 404), (code, answer.status_code)
    assert client.get(f"/pi/participants/P001/withdraw?study={HUGE}").status_code == 422


def test_a_lone_surrogate_in_json_text_is_a_422(
    client: TestClient, pi: StaffApi, wizard: WizardBot
) -> None:
    raw = '{"text": "half a pair: \\ud800"}'
    status, detail = _post_raw(client, f"/api/sessions/{wizard.session_id}/notes", raw, pi.csrf)
    assert (status, detail) == (422, NOT_UNICODE)
    # A proper pair is text like any other.
    raw = '{"text": "a pair: \\ud83d\\ude00"}'
    assert _post_raw(client, f"/api/sessions/{wizard.session_id}/notes", raw, pi.csrf)[0] == 201


def test_a_study_file_with_control_characters_is_a_422(client: TestClient, pi: StaffApi) -> None:
    status, detail = _post_raw(client, "/api/studies", '{"yaml": "name: x\\u0089"}', pi.csrf)
    assert status == 422
    assert "not valid YAML" in str(detail)


@pytest.mark.parametrize(
    "path", [f"/ws/sessions/{HUGE}", f"/ws/wizard/sessions/{MAX_ROW_ID + 1}", "/ws/p/a%00b"]
)
def test_a_websocket_address_no_database_can_look_up_is_refused(
    client: TestClient, pi: StaffApi, path: str
) -> None:
    with pytest.raises(WebSocketDisconnect) as refused, client.websocket_connect(path):
        pass
    assert refused.value.code == 1008


SWEDISH_NUL = "Texten får inte innehålla ett NUL-tecken (0x00). Ta bort det och försök igen."


@pytest.mark.parametrize(
    ("accept", "expected"),
    [("sv", SWEDISH_NUL), ("de, sv;q=0.5", SWEDISH_NUL), ("", NUL_IN_TEXT), ("de", NUL_IN_TEXT)],
)
def test_the_phones_refusals_are_in_the_language_it_asks_for(
    client: TestClient, wizard: WizardBot, accept: str, expected: str
) -> None:
    """The phone sends its page's language; a language without a catalogue gets English."""
    headers = {**HEADERS, **({"Accept-Language": accept} if accept else {})}
    raw = (
        '{"client_id": "abcdefgh12345678", "position": -1, "questionnaire": "about_you",'
        ' "answers": {"comment": "hello\\u0000world"}}'
    )
    path = f"/api/phone/{wizard.token}/questionnaire"
    answer = client.post(path, content=raw.encode(), headers=headers)
    assert (answer.status_code, answer.json()["detail"]) == (422, expected)
    surrogate = raw.replace("hello\\u0000world", "\\ud800")
    answer = client.post(path, content=surrogate.encode(), headers=headers)
    language = "sv" if expected == SWEDISH_NUL else "en"
    assert answer.json()["detail"] == gettext(language, NOT_UNICODE)
    assert ("surrogatkod" in answer.json()["detail"]) == (language == "sv")
    address = client.get(f"/api/phone/{wizard.token}/state?x=%00", headers=headers)
    assert (address.status_code, address.json()["detail"]) == (
        400,
        gettext(language, NUL_IN_ADDRESS),
    )


def test_staff_refusals_stay_in_english_whatever_the_browser_asks_for(
    client: TestClient, pi: StaffApi, wizard: WizardBot
) -> None:
    headers = {**HEADERS, "X-CSRF-Token": pi.csrf, "Accept-Language": "sv"}
    path = f"/api/sessions/{wizard.session_id}/notes"
    answer = client.post(path, content=b'{"text": "a\\u0000b"}', headers=headers)
    assert (answer.status_code, answer.json()["detail"]) == (422, NUL_IN_TEXT)


@pytest.mark.parametrize("query", ["limit=-107", "limit=0", "limit=5001", "after=-59"])
def test_the_timeline_refuses_a_count_it_cannot_read_with_a_sentence(
    client: TestClient, wizard: WizardBot, query: str
) -> None:
    """A negative LIMIT is an error on PostgreSQL (the OpenAPI fuzz found it as a 500)."""
    response = client.get(f"/api/sessions/{wizard.session_id}/events?{query}")
    assert response.status_code == 422
    name = query.split("=")[0]
    assert any(name in str(problem.get("loc")) for problem in response.json()["detail"])
    assert client.get(f"/api/sessions/{wizard.session_id}/events?limit=5000").status_code == 200
