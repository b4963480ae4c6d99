"""scripts/setup's solver build: a stamp per code and yaml version, so a second setup does not compile again."""

from conftest import ROOT

from teleteach.shared_control import cache, prebuild


def test_the_stamp_follows_the_yaml_and_a_stamped_cache_is_not_built_again(tmp_path, monkeypatch, capsys):
    monkeypatch.setenv("TELETEACH_CACHE", str(tmp_path / "cache"))
    config = ROOT / "config" / "shared_control.yaml"
    other = tmp_path / "other.yaml"
    other.write_text(config.read_text().replace("window_time: 0.8", "window_time: 0.9"))
    assert prebuild.stamp(config) == prebuild.stamp(config)
    assert prebuild.stamp(config) != prebuild.stamp(other)
    # Expect: with the yaml's stamp in the cache, main says "cached" and builds nothing (no library appears).
    cache.cache_dir().mkdir(parents=True)
    (cache.cache_dir() / f".prebuilt-{prebuild.stamp(config)[:16]}").touch()
    assert prebuild.main(["--config", str(config)]) == 0
    assert capsys.readouterr().out.strip().endswith(f"cached ({cache.cache_dir()})")
    assert not list(cache.cache_dir().glob("*.so"))
