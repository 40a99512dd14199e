"""What a new user meets in the first minute of a notebook: a map named after its system, warnings
in their words that appear once and point at their own line, a progress bar only when someone
watches, and a notice (once) that the first call compiles."""

import logging

import pytest

import ldpipe
from ldpipe import jitcache, logs
from ldpipe.core.maps.symmetry import MapMirror
from ldpipe.errors import LdpipeWarning
from support.henon_heiles import HENON_HEILES

#: The API tests' Hénon–Heiles settings (the same engine module).
INTEGRATOR = {"scheme": "dop853", "rtol": 1e-8, "atol": 1e-8}


@pytest.fixture(scope="module")
def hh():
    return ldpipe.system(name="henon_heiles", **HENON_HEILES)


def _section(py=(-0.5, 0.5, 9)):
    return ldpipe.section(y=(-0.45, 0.8, 11), py=py, fixed={"px": 0.0}, solve="x", root="largest")


def test_a_map_is_named_after_its_system_by_default(hh):
    ld = ldpipe.ld_map(hh, section=_section(), energy=0.125, tau=2.0, integrator=INTEGRATOR)
    assert ld.attrs["map"] == "henon_heiles" and ld.attrs["title"] == "Lagrangian descriptor map henon_heiles"


@pytest.mark.parametrize("tiles", [1, 2])
def test_an_empty_map_warns_once_in_the_users_words_at_the_users_line(hh, tiles):
    """H >= V >= 0 on this section (closed form: V = x² (1/2 + y) + y² (1/2 - y/3) >= 0 for y in
    [-0.45, 0.8]), so at E = -1 no point is allowed: one warning, in one piece or in tiles."""
    with pytest.warns(LdpipeWarning) as record:
        empty = ldpipe.ld_map(hh, section=_section(), energy=-1.0, tau=2.0, integrator=INTEGRATOR, tiles=tiles)
    assert len(record) == 1, [str(w.message) for w in record]
    message = str(record[0].message)
    assert message.startswith("map 'henon_heiles' is empty") and "Raise the energy or move the section" in message
    assert record[0].filename == __file__  # the user's call, not ldpipe's internals
    assert empty.attrs["warning"] == message and empty.attrs["allowed_points"] == 0


def test_a_backward_half_not_mirrored_is_told_once_in_the_users_words_and_is_no_warning(hh, monkeypatch, caplog,
                                                                                       recwarn):
    """Hénon–Heiles is reversible (S: p -> -p) and this grid is centred, so its backward half is
    mirrored. Where a tile's grid points miss their mirror images (the solved coordinate's
    rounding near the rim, as in the README's own example; made to happen here), the tile
    integrates backward: the map is right, so this is information in the log, said once for the
    map however many tiles fell back, with what it means, and no warning."""
    mirrored = ldpipe.ld_map(hh, section=_section(), energy=0.125, tau=2.0, integrator=INTEGRATOR, tiles=2)
    assert "backward_fields" in mirrored.attrs and "reversing_symmetry_unused" not in mirrored.attrs
    monkeypatch.setattr(MapMirror, "maps_grid", lambda self, grid, allowed: False)
    with caplog.at_level(logging.INFO, logger="ldpipe"):
        ld = ldpipe.ld_map(hh, section=_section(), energy=0.125, tau=2.0, integrator=INTEGRATOR, tiles=2)
    told = [r.getMessage() for r in caplog.records if "the backward half was integrated" in r.getMessage()]
    assert len(told) == 1, told
    assert told[0].startswith("map 'henon_heiles': the backward half was integrated, not mirrored")
    assert "its values are right" in told[0] and "the solved coordinate x rounds differently" in told[0]
    assert len(recwarn) == 0
    assert "backward_fields" not in ld.attrs and ld.attrs["reversing_symmetry_unused"] in told[0]


def test_in_a_stage_the_warning_goes_to_the_log_only(caplog, recwarn):
    with logs.log_to(None), caplog.at_level(logging.WARNING, logger="ldpipe"):
        logs.warn_user(logging.getLogger("ldpipe.test"), "told once")
    assert [r.getMessage() for r in caplog.records if r.levelno == logging.WARNING] == ["told once"]
    assert len(recwarn) == 0


def test_progress_shows_by_default_only_to_someone_watching(monkeypatch):
    monkeypatch.setattr(logs, "interactive", lambda: False)
    with logs.progress_bar(logs.get_logger("ldpipe.test"), show=None, total=3) as bar:
        assert bar.disable  # a script's log, a batch job: no bar
    monkeypatch.setattr(logs, "interactive", lambda: True)
    with logs.progress_bar(logs.get_logger("ldpipe.test"), show=None, total=3) as bar:
        assert not bar.disable and bar.delay == logs.PROGRESS_DELAY_S  # a short map shows none
    monkeypatch.setattr(logs, "interactive", lambda: False)
    with logs.progress_bar(logs.get_logger("ldpipe.test"), show=True, total=3) as bar:
        assert not bar.disable and bar.delay == 0  # asked for: always, at once


def test_a_compile_is_announced_once_and_a_cached_one_not_at_all(tmp_path, monkeypatch, capsys):
    """The notice's rules, without compiling: once per module, once for the modules one call
    compiles in a row, never inside another module's compile, never for what numba's cache holds."""
    monkeypatch.setattr(logs, "interactive", lambda: True)
    monkeypatch.setattr(jitcache.CompileLock, "announced", set())
    monkeypatch.setattr(jitcache.CompileLock, "last_notice", -float("inf"))
    monkeypatch.delenv("NUMBA_CACHE_DIR", raising=False)

    def lock(name):
        return jitcache.CompileLock(tmp_path / f"ldpipe_generated_{name}_0123456789abcdef0123.lock",
                                    f"ldpipe_generated_{name}_0123456789abcdef0123")

    kernels, engine = lock("formula_henon_heiles"), lock("engine_henon_heiles_dop853_64")
    kernels.announce("potential_block")
    kernels.announce("potential_block")
    engine.announce("process")  # the same call's next compile
    lines = capsys.readouterr().err.splitlines()
    assert len(lines) == 1 and lines[0].startswith("ldpipe: compiling the engine of 'formula_henon_heiles'")
    assert "10 to 60 s" in lines[0]
    monkeypatch.setattr(jitcache.CompileLock, "last_notice", -float("inf"))  # a later call, minutes on
    cached = lock("engine_duffing_dop853_64")
    (tmp_path / "__pycache__").mkdir()
    tag = f"py{jitcache.sys.version_info.major}{jitcache.sys.version_info.minor}"
    (tmp_path / "__pycache__" / f"{cached.module}.process-12.{tag}.nbi").write_text("")
    cached.announce("process")  # numba loads it: nothing to wait for
    monkeypatch.setattr(jitcache.CompileLock, "held", [engine])
    lock("common_quadrature").announce("ld_step")  # compiled inside the engine's compile
    assert capsys.readouterr().err == ""
