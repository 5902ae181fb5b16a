"""readme_check: the bad inputs it refuses before running anything (the run itself needs the built CLI and the
H3.6M data; `select_game --readme`'s tests read its output format)."""

from training import readme_check


def test_a_missing_model_or_cli_exits_2_naming_it(tmp_path, capsys):
    cli = tmp_path / "motion-cli"
    assert readme_check.main(["--model", str(tmp_path / "m.safetensors"), "--out", str(tmp_path / "o.json"),
                              "--cli", str(cli)]) == 2
    assert str(cli) in capsys.readouterr().err
    cli.write_text("")
    assert readme_check.main(["--model", str(tmp_path / "m.safetensors"), "--out", str(tmp_path / "o.json"),
                              "--cli", str(cli)]) == 2
    assert "m.safetensors: no such model file" in capsys.readouterr().err
    assert not (tmp_path / "o.json").exists()
