"""A compile of the shared controller's solvers that fails says why: the compiler's words, or how it was stopped."""

import pytest

from teleteach.shared_control import cache


def test_a_compiler_error_is_quoted(tmp_path):
    def broken_code(file_name):
        with open(file_name, "w") as source:
            source.write("int broken( {\n")

    with pytest.raises(RuntimeError) as error:
        cache._compile(broken_code, "broken", str(tmp_path))
    message = str(error.value)
    assert message.startswith("compiling broken failed: gcc exit status 1: ") and "error" in message, message


def test_a_compiler_killed_by_a_signal_says_so(tmp_path, monkeypatch):
    # what Ctrl-C does to a compile under way: the compiler ends by a signal and prints nothing
    monkeypatch.setattr(cache, "COMPILER", ("sh", "-c", "kill -TERM $$", "sh"))

    def code(file_name):
        with open(file_name, "w") as source:
            source.write("int fine(void) { return 0; }\n")

    with pytest.raises(RuntimeError) as error:
        cache._compile(code, "stopped", str(tmp_path))
    assert str(error.value) == "compiling stopped failed: sh killed by signal 15, printing nothing"
