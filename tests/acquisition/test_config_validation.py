"""Config validation, field by field: every key of every table, given a value of the wrong type
or range, is one error naming the table, the key, the value (as TOML spells it) and what was
expected. The tests walk the schemas, so a field added later is tested too."""

from __future__ import annotations

import dataclasses

import pytest

from snrmon.acquisition.config import (
    CAMERA_FIELDS,
    MEASUREMENT_FIELDS,
    SITE_FIELDS,
    TOP_FIELDS,
    WEATHER_FIELDS,
    CameraConfig,
    SessionConfig,
    load_session_config,
    session_config_from_dict,
)
from snrmon.acquisition.measure.peak_snr import PeakSnrConfig
from snrmon.drivers.config import PROTOCOLS, device_fields, device_from_config
from snrmon.drivers.errors import ConfigError, toml_repr
from snrmon.model.presets import _ATM_FIELDS, _SENSOR_FIELDS, _TARGET_FIELDS, _check

# Values of every TOML type; each field must reject at least one of them.
WRONG = ["north", 1.5, -3, True, [1, "a"], {"x": 1}, 0, ""]
BASE = {"cameras": {"cam": {"source": "shm"}}}


def _with(table: str, key: str, value):
    doc = {"cameras": {"cam": {"source": "shm"}}}
    if table == "session":
        doc[key] = value
    elif table == "cameras.cam":
        doc["cameras"]["cam"][key] = value
    elif table == "site":
        doc["site"] = {"lat_deg": 1.0, "lon_deg": 2.0, "alt_m": 3.0, key: value}
    else:
        doc[table] = {key: value}
    return doc


CASES = [
    (table, key, spec)
    for table, fields in (
        ("session", TOP_FIELDS),
        ("site", SITE_FIELDS),
        ("measurement", MEASUREMENT_FIELDS),
        ("weather", WEATHER_FIELDS),
        ("cameras.cam", CAMERA_FIELDS),
    )
    for key, spec in fields.items()
]


@pytest.mark.parametrize(("table", "key", "spec"), CASES, ids=[f"{t}.{k}" for t, k, _ in CASES])
def test_every_session_field_names_table_key_value_and_type(table, key, spec):
    rejected = [v for v in WRONG if not spec.check(v)]
    assert rejected, f"[{table}] {key} accepts values of every type"
    for value in rejected:
        with pytest.raises(ConfigError) as err:
            session_config_from_dict(_with(table, key, value))
        msg = str(err.value)
        if table == "session" and key in ("gps", "lrf", "site", "measurement") and value == {}:
            continue  # an empty table: its own required keys are what is missing
        if isinstance(value, dict) and table != "session":
            assert f"[{table}] {key} = " in msg and spec.expected in msg
            continue
        assert f"[{table}] {key} = {toml_repr(value)}: expected {spec.expected}" in msg, msg


def test_the_schema_covers_every_field_of_the_config_dataclasses():
    """A new setting needs its schema entry (and so its validation and this file's tests)."""
    camera_keys = {f.name for f in dataclasses.fields(CameraConfig)} - {"name", "pointing"}
    assert camera_keys | {"pointing_deg"} == set(CAMERA_FIELDS)
    peak = {f.name for f in dataclasses.fields(PeakSnrConfig)}
    assert peak | {"window_frames", "window", "lrf_fresh_s"} == set(MEASUREMENT_FIELDS)
    session = {f.name for f in dataclasses.fields(SessionConfig)}
    # [weather] air_temp_c becomes air_temp_k; [simulation] is kept in raw (the scenario)
    assert session - {"raw", "window_frames", "lrf_fresh_s", "air_temp_k"} | {
        "weather",
        "simulation",
    } == (set(TOP_FIELDS))
    # [weather] is the model's met readings: every field of Weather
    from snrmon.model.atmosphere_table import Weather

    assert set(WEATHER_FIELDS) == {f.name for f in dataclasses.fields(Weather)}


def test_the_issue_examples(tmp_path):
    path = tmp_path / "session.toml"
    path.write_text('[site]\nlat_deg = "north"\nlon_deg = 0.0\nalt_m = 0.0\n[cameras.a]\n')
    with pytest.raises(ConfigError) as err:
        load_session_config(path)
    assert str(err.value) == (
        f'{path}: [site] lat_deg = "north": expected a latitude in degrees, -90 to 90'
    )
    path.write_text('[cameras.mwir]\nwidth_px = "640"\n')
    with pytest.raises(ConfigError, match=r'\[cameras\.mwir\] width_px = "640": expected a pos'):
        load_session_config(path)


def test_unknown_and_missing_keys_are_named():
    with pytest.raises(ConfigError, match=r"\[cameras\.cam\]: unknown key 'colour'"):
        session_config_from_dict({"cameras": {"cam": {"colour": "red"}}})
    with pytest.raises(ConfigError, match=r"\[site\] is missing 'alt_m'"):
        session_config_from_dict({**BASE, "site": {"lat_deg": 1.0, "lon_deg": 2.0}})
    with pytest.raises(ConfigError, match=r"\[session\] is missing 'cameras'"):
        session_config_from_dict({})


def test_a_valid_config_keeps_its_values():
    cfg = session_config_from_dict(
        {
            "target": "uav2",
            "site": {"lat_deg": 32, "lon_deg": -106.5, "alt_m": 1200},
            "measurement": {"search_px": 15, "window_frames": 50, "background": [0, 0, 9, 9]},
            "cameras": {
                "m": {
                    "source": "v4l2",
                    "address": 0,
                    "width_px": 640,
                    "height_px": 480,
                    "pointing_deg": [40, 8],
                }
            },
            "gps": {"protocol": "nmea", "port": "/dev/ttyUSB0", "baud": 38400},
        }
    )
    assert cfg.site.lat_deg == 32.0 and cfg.window_frames == 50 and cfg.measurement.search_px == 15
    assert cfg.measurement.background == (0, 0, 9, 9)
    cam = cfg.cameras[0]
    assert (cam.address, cam.width_px, cam.pointing.el_deg) == ("0", 640, 8.0)


DEVICE_CASES = [
    (protocol, key, spec)
    for protocol in PROTOCOLS
    for key, spec in device_fields(protocol).items()
    if key != "protocol"
]


@pytest.mark.parametrize(
    ("protocol", "key", "spec"), DEVICE_CASES, ids=[f"{p}.{k}" for p, k, _ in DEVICE_CASES]
)
def test_every_device_field_names_table_key_value_and_type(protocol, key, spec):
    rejected = [v for v in WRONG if not spec.check(v)]
    assert rejected, f"[gps] {key} accepts values of every type"
    for value in rejected:
        table = {"protocol": protocol, "port": "/dev/ttyUSB0", key: value}
        with pytest.raises(ConfigError) as err:
            device_from_config(table, "gps")
        assert f"[gps] {key} = {toml_repr(value)}: expected {spec.expected}" in str(err.value)
        # ... and the same check runs when a session config is loaded, before any device opens.
        with pytest.raises(ConfigError, match=rf"\[gps\] {key} = "):
            session_config_from_dict({**BASE, "gps": table})


PRESET_CASES = [
    (table, key, spec)
    for table, fields in (
        ("sensor", _SENSOR_FIELDS),
        ("target", _TARGET_FIELDS),
        ("atmosphere", _ATM_FIELDS),
    )
    for key, spec in fields.items()
]


@pytest.mark.parametrize(
    ("table", "key", "spec"), PRESET_CASES, ids=[f"{t}.{k}" for t, k, _ in PRESET_CASES]
)
def test_every_preset_field_names_file_table_key_value_and_type(table, key, spec, tmp_path):
    rejected = [v for v in WRONG if not spec.check(v)]
    assert rejected, f"[{table}] {key} accepts values of every type"
    path = tmp_path / "x.toml"
    for value in rejected:
        with pytest.raises(ValueError) as err:
            _check(path, table, {key: value}, {key: spec})
        expected = f"{path}: [{table}] {key} = {toml_repr(value)}: expected {spec.expected}"
        assert str(err.value) == expected


def test_one_schema_mechanism_for_the_session_the_devices_and_the_presets():
    """The three layers declare their tables with snrmon.config_schema's Key, so one check and
    one message form serve them all."""
    from snrmon.config_schema import Key

    tables = [TOP_FIELDS, SITE_FIELDS, MEASUREMENT_FIELDS, WEATHER_FIELDS, CAMERA_FIELDS]
    tables += [device_fields(p) for p in PROTOCOLS]
    tables += [_SENSOR_FIELDS, _TARGET_FIELDS, _ATM_FIELDS]
    assert all(isinstance(spec, Key) for t in tables for spec in t.values())


def test_the_template_loads_as_a_valid_config_and_names_every_key(tmp_path):
    """`snrmon doctor --template` writes every key of every session table with what it expects,
    its default or an example; as written it loads as the declared defaults with one camera."""
    import tomllib

    from snrmon.acquisition.config import SCHEMA, session_template

    text = session_template()
    doc = tomllib.loads(text)
    for name, keys in SCHEMA.items():
        for key in keys:
            if key == "window" or (name == "" and key not in ("target", "compression")):
                continue
            assert f"{key} = " in text or f"# {key} =" in text, (name, key)
    for protocol in ("nmea", "trupulse"):
        for key in device_fields(protocol):
            assert f"{key} = " in text or f"# {key} =" in text, (protocol, key)
    path = tmp_path / "session.toml"
    path.write_text(text)
    cfg = load_session_config(path)
    assert cfg.target == "uav1" and cfg.compression == "bitshuffle-lz4"
    assert cfg.window_frames == 100 and cfg.measurement == PeakSnrConfig()
    assert [c.name for c in cfg.cameras] == ["mwir"] and cfg.gps is None and cfg.weather is None
    assert doc == {"cameras": {"mwir": {"address": "snrmon-mwir", "sensor": "mwir"}}}
    assert '# aerosol = "rural"   # one of rural, maritime, urban' in text
    assert '# port = "/dev/ttyUSB0"' in text and "# [gps]" in text and "# [lrf]" in text


def test_the_frames_filter_is_the_default_unless_named():
    assert session_config_from_dict(BASE).compression == "bitshuffle-lz4"
    assert session_config_from_dict({**BASE, "compression": "none"}).compression == "none"
    with pytest.raises(ConfigError, match=r'\[session\] compression = "snappy": expected'):
        session_config_from_dict({**BASE, "compression": "snappy"})


def test_the_old_window_key_still_works_and_warns_once(tmp_path, caplog):
    """``[measurement] window`` (the running SNR's frames) is now ``window_frames``, the name the
    command line uses (``--window-frames``); a session TOML with the old key still loads, with one
    warning naming the file; a recorded session's config loads without one."""
    import logging

    from snrmon.acquisition.config import load_session_config, session_config_from_dict

    doc = '[cameras.cam]\naddress = "x"\n[measurement]\nwindow = 50\n'
    path = tmp_path / "old.toml"
    path.write_text(doc)
    with caplog.at_level(logging.WARNING):
        cfg = load_session_config(path)
    assert cfg.window_frames == 50
    warned = [r.getMessage() for r in caplog.records if "deprecated" in r.getMessage()]
    assert warned == [f"{path}: [measurement] window is deprecated, use window_frames"]
    caplog.clear()
    with caplog.at_level(logging.WARNING):
        raw = {"cameras": {"cam": {"address": "x"}}, "measurement": {"window": 50}}
        assert session_config_from_dict(raw).window_frames == 50
    assert not [r for r in caplog.records if "deprecated" in r.getMessage()]
    path.write_text(doc + "window_frames = 50\n")
    with pytest.raises(ValueError, match="not also its old name window"):
        load_session_config(path)


def test_the_models_psf_and_footprint_are_the_fitted_and_the_square_unless_named(tmp_path):
    """``model_psf`` (fitted from the flight, or the preset's) and ``footprint`` (the
    paper's square, or the target file's outline): an outline asked of a target without one is
    refused at load, naming both."""
    config = session_config_from_dict(BASE)
    assert (config.model_psf, config.footprint) == ("fitted", "square")
    named = session_config_from_dict({**BASE, "model_psf": "preset"})
    assert named.model_psf == "preset"
    path = tmp_path / "session.toml"
    path.write_text('footprint = "outline"\n[cameras.cam]\nsource = "shm"\n')
    with pytest.raises(ConfigError, match=r'footprint = "outline": target = "uav1" has no'):
        load_session_config(path)


def test_the_operator_guide_lists_every_key_as_the_schema_declares_it():
    """docs/operator-guide.md's key tables are the schema's own text (regenerate them with
    ``snrmon.acquisition.config.key_tables_markdown()``)."""
    from pathlib import Path

    from snrmon.acquisition.config import key_tables_markdown

    doc = (Path(__file__).parents[2] / "docs" / "operator-guide.md").read_text()
    begin, end = "<!-- session keys: begin -->\n", "<!-- session keys: end -->"
    assert doc[doc.index(begin) + len(begin) : doc.index(end)] == key_tables_markdown()
