"""``--policy model.zip --algo ALGO``: a crafted zip is refused before anything in it runs, ``--algo`` must be
the algorithm the zip records, and every bad file or option is one line naming it."""

from __future__ import annotations

import pickle
import re
from pathlib import Path

import pytest
from pickle_payloads import (
    PAYLOADS,
    call,
    rewritten,
    stack_global,
    stream,
    text,
    tiny_model,
    with_policy_kwargs,
)

from agents.cli import main
from agents.common.saved_models import read_saved_model
from agents.policies import load_agent
from agents.policies.sb3_models import SB3_ALGORITHMS, network_parameters, recorded_algorithm, sb3_model_name

TORCH_LAYERS = "stable_baselines3.common.torch_layers"


@pytest.fixture(scope="module")
def ppo_zip(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return tiny_model("ppo", tmp_path_factory.mktemp("ppo"))


def score(policy: Path | str, algo: str, out: Path, *options: str) -> list[str]:
    return ["score", "--policy", str(policy), "--algo", algo, "--out", str(out), *options]


def one_error_line(capsys: pytest.CaptureFixture[str], command: str = "score") -> str:
    error = capsys.readouterr().err
    assert error.count("\n") == 1 and error.startswith(f"flownav {command}: error: "), error
    return error.strip()


def test_score_refuses_the_zip_that_ran_a_shell_command_before_it_runs(
    ppo_zip: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    marker = tmp_path / "pwned"
    command = stream(call(stack_global(TORCH_LAYERS, "th.os.system"), text(f"touch {marker}")))
    crafted = with_policy_kwargs(ppo_zip, tmp_path / "crafted.zip", command)
    assert main(score(crafted, "ppo", tmp_path / "out")) == 2
    assert one_error_line(capsys) == (
        f"flownav score: error: {crafted}: its policy_kwargs are pickled and the pickle names 'th.os.system' of "
        f"module '{TORCH_LAYERS}' (a dotted name, an attribute path inside the module), which is not one of the "
        "torch activations, torch optimisers and SB3 features extractors it may name; only unpickling it, which "
        "runs code from the file, can read it: pass --trust-pickle (trust_pickle=True) only if you trust the file"
    )
    assert not marker.exists() and not (tmp_path / "out").exists()


@pytest.mark.parametrize("form", sorted(PAYLOADS))
def test_loading_a_model_refuses_each_way_of_calling_code(ppo_zip: Path, form: str, tmp_path: Path) -> None:
    marker = tmp_path / "pwned"
    crafted = with_policy_kwargs(ppo_zip, tmp_path / "crafted.zip", PAYLOADS[form](TORCH_LAYERS, marker))
    message = (
        rf"^{re.escape(str(crafted))}: its policy_kwargs are pickled and the pickle names '__builtins__\.get'"
    )
    with pytest.raises(ValueError, match=message):
        load_agent(sb3_model_name("ppo", crafted))
    assert not marker.exists()


@pytest.mark.parametrize("sandboxed", [True, False])
def test_a_trusted_payload_that_breaks_the_load_is_one_line_naming_the_file(
    ppo_zip: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str], sandboxed: bool
) -> None:
    marker = tmp_path / "pwned"
    crafted = with_policy_kwargs(
        ppo_zip, tmp_path / "crafted.zip", PAYLOADS["STACK_GLOBAL+REDUCE"](TORCH_LAYERS, marker)
    )
    extra = () if sandboxed else ("--no-sandbox",)
    assert main(score(crafted, "ppo", tmp_path / "out", "--trust-pickle", *extra)) == 2
    error = one_error_line(capsys)
    # SB3 gets something other than its keyword arguments, and fails on it: said in one line.
    prefix = f"flownav score: error: {crafted} could not be loaded as a ppo model (unpickled, as --trust-pickle asked): "
    assert error.startswith(prefix) and re.match(r"\w+: \S", error[len(prefix) :]), error
    # Trusting the file is what let its code run: in the sandbox it could not write the user's files.
    assert marker.exists() == (not sandboxed)


def test_algo_must_be_the_algorithm_the_zip_records(
    ppo_zip: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    assert main(score(ppo_zip, "a2c", tmp_path / "out")) == 2
    assert one_error_line(capsys) == (
        f"flownav score: error: {ppo_zip.resolve()} records a ppo model, not the --algo a2c asked for: pass --algo ppo"
    )
    assert not (tmp_path / "out").exists()


@pytest.mark.parametrize("algo", SB3_ALGORITHMS)
def test_each_algorithm_is_told_from_what_its_zip_records(algo: str, tmp_path: Path) -> None:
    assert recorded_algorithm(read_saved_model(tiny_model(algo, tmp_path)).data) == algo


def test_a_zip_that_records_no_algorithm_says_so(ppo_zip: Path, tmp_path: Path) -> None:
    bare = rewritten(ppo_zip, tmp_path / "bare.zip", lambda data: data.pop("policy_class"))
    message = (
        rf"^{re.escape(str(bare))} records no algorithm FlowNav can tell \(policy class module None\), so --algo "
        r"ppo cannot be checked: it must be a model saved by stable-baselines3's or sb3-contrib's ppo, sac, a2c"
    )
    with pytest.raises(ValueError, match=message):
        load_agent(sb3_model_name("ppo", bare))


@pytest.mark.parametrize("command", ["score", "evaluate"])
def test_a_policy_without_zip_is_named_as_not_a_model_file(
    command: str, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    policy = tmp_path / "model"
    assert main([command, "--policy", str(policy), "--algo", "ppo", "--out", str(tmp_path / "out")]) == 2
    assert one_error_line(capsys, command) == (
        f"flownav {command}: error: --policy {policy}: a stable-baselines3 model must be a .zip file (what "
        "model.save writes), not a name without one"
    )
    with pytest.raises(
        ValueError, match=r"^--policy model\.pt: a stable-baselines3 model must be a \.zip file"
    ):
        sb3_model_name("sac", "model.pt")


def test_score_calls_a_truncated_zip_cut_short(
    ppo_zip: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    cut = tmp_path / "cut.zip"
    cut.write_bytes(ppo_zip.read_bytes()[: ppo_zip.stat().st_size * 9 // 10])
    assert main(score(cut, "ppo", tmp_path / "out")) == 2
    assert one_error_line(capsys).startswith(
        f"flownav score: error: {cut} is cut short: not a readable zip file"
    )


def test_a_model_whose_network_would_fill_memory_is_refused_before_it_is_built(
    ppo_zip: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    huge = with_policy_kwargs(ppo_zip, tmp_path / "huge.zip", pickle.dumps({"net_arch": [200000, 200000]}))
    assert main(score(huge, "ppo", tmp_path / "out", "--tiers", "clean", "--layouts", "1")) == 2
    assert re.fullmatch(
        rf"flownav score: error: {re.escape(str(huge))}: its network \(net_arch \[200000, 200000\]\) would have "
        r"about 80,0\d\d,\d{3},\d{3} parameters, more than the 20,000,000 FlowNav builds a model with",
        one_error_line(capsys),
    )


@pytest.mark.parametrize(
    ("net_arch", "count"),
    [
        ([8], 2 * (10 * 8 + 8 + 8 * 3 + 3)),
        ({"pi": [4, 4], "vf": [2]}, (10 * 4 + 4 + 4 * 4 + 4 + 4 * 3 + 3) + (10 * 2 + 2 + 2 * 3 + 3)),
    ],
)
def test_a_network_is_counted_from_its_layer_sizes(net_arch: object, count: int) -> None:
    assert network_parameters(net_arch, 10, 3) == count


def test_layer_sizes_that_are_not_positive_integers_are_refused() -> None:
    with pytest.raises(
        ValueError, match=r"^net_arch must be lists of layer sizes \(integers > 0\), got \[8, -1\]$"
    ):
        network_parameters([8, -1], 10, 3)
