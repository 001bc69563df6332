"""The recorded real-model corpus: its cases, how it was recorded, and a responder that replays it.

``tests/fixtures/llm_corpus/cases.json`` names eight uses outside the registry, each with demo objects and a real
mesh and the label a person gives. To record a model (docs/llm.md)::

    python -m rail_mj.llm.relay --dir RELAY &        # answer each RELAY/NNNN.prompt.md in RELAY/NNNN.answer.json
    python tests/helpers/corpus.py record "fruit bowl" --relay http://127.0.0.1:8765/v1 --out RESULTS.jsonl
    python tests/helpers/corpus.py keep RELAY RESULTS.jsonl...   # writes the fixture's exchanges and verdicts
    python tests/helpers/corpus.py keep RELAY RESULTS.jsonl --only footrest   # re-recorded uses only

:class:`Replay` answers a provider's request (OpenAI's or Anthropic's format) with the recorded answer to the same
stage request: stage 0 by the use's name, stage 7 by the use and each pose's candidate plans (the rollouts'
numbers may move a little with the physics; the question asked does not), any other stage by its whole request.
"""

from __future__ import annotations

import argparse
import json
import os
import sys
from pathlib import Path
from typing import Any

from messages_server import request_payload
from paths import FIXTURES

from rail_mj.core.paths import cache_dir
from rail_mj.core.results import AffordanceResult
from rail_mj.core.types import RailObject
from rail_mj.dataset.labels import read_labels
from rail_mj.pipeline.chain import classify
from rail_mj.pipeline.config import ObjectInput, RunConfig
from rail_mj.robot.demo import make_object

CORPUS = FIXTURES / "llm_corpus"
CASES: dict[str, list[dict[str, Any]]] = json.loads((CORPUS / "cases.json").read_text())["cases"]
#: the model that answered, as the recording named it
MODEL = "helper-agent"


def real_root() -> Path | None:
    """The real-mesh development set when this machine has it ($RAIL_MJ_REAL_DATA or the cache); never fetched."""
    for folder in (os.environ.get("RAIL_MJ_REAL_DATA"), cache_dir("real_data")):
        if folder and (Path(folder) / "labels.jsonl").is_file():
            return Path(folder)
    return None


def case_object(case: dict[str, Any], root: Path | None) -> RailObject | ObjectInput | None:
    """The case's object; None for a real mesh this machine does not have."""
    if "demo" in case:
        return make_object(case["demo"], 0, scale=case["scale"])
    if root is None:
        return None
    record = next(r for r in read_labels(root) if r.mesh == case["real"])
    return ObjectInput(path=root / record.mesh, units=record.units, up=record.up, name=Path(record.mesh).stem)


def case_name(case: dict[str, Any]) -> str:
    return f"{case['demo']}_0_x{case['scale']:g}" if "demo" in case else Path(case["real"]).stem


def attempt(body: dict[str, Any]) -> int:
    """0 for a stage's first request, k for its k-th repair round."""
    return sum(m["role"] == "assistant" for m in body["messages"])


def key(schema: str, request: dict[str, Any], tries: int) -> str:
    if schema == "AffordanceDefinition":
        what: Any = request["affordance"]
    elif schema == "FunctionalPoseVerdict":
        what = [request["affordance"], [[p["pose_index"], sorted(c["plan"] for c in p["candidates"])]
                                       for p in request["poses"]]]
    else:
        what = request
    return json.dumps([schema, what, tries], sort_keys=True)


class Replay:
    """Answers each request with the recorded answer to the same question; ``missing`` lists those it had none
    for (answered HTTP 400 by the caller's ``error``)."""

    def __init__(self, schema_of, reply, error, path: Path | None = None) -> None:
        self.answers = {key(e["schema"], e["request"], e["attempt"]): e["answer"] for e in exchanges(path)}
        self.schema_of, self.reply, self.error = schema_of, reply, error
        self.missing: list[str] = []
        self.served = 0

    def __call__(self, body: dict[str, Any]):
        k = key(self.schema_of(body), request_payload(body), attempt(body))
        if k not in self.answers:
            self.missing.append(k)
            return self.error(400, f"the recorded corpus has no answer to {k[:300]}: re-record it (docs/llm.md)")
        self.served += 1
        return self.reply(self.answers[k])


def exchanges(path: Path | None = None) -> list[dict[str, Any]]:
    path = path or CORPUS / "exchanges.jsonl"
    return [json.loads(line) for line in path.read_text().splitlines() if line.strip()]


def verdicts() -> dict[str, dict[str, Any]]:
    """The recorded run's verdict per case (``use::object``)."""
    path = CORPUS / "verdicts.jsonl"
    return {v["case"]: v for v in map(json.loads, path.read_text().splitlines()) if v}


def run(name: str, objects: list, base_url: str, provider: str = "openai",
        timeout: float | None = None) -> list[AffordanceResult]:
    # recorded as text: stage 7 went without pictures
    config = RunConfig(provider=provider, backend="native", max_retries=2, cache=False, llm_timeout=timeout,
                       provider_options={"base_url": base_url, "pictures": False})
    return classify(objects, [name], config=config, progress=False, workers=1)


def _record(args: argparse.Namespace) -> int:
    root = real_root()
    cases = CASES[args.name]
    objects = [case_object(c, root) for c in cases]
    if any(o is None for o in objects):
        sys.exit("the real-mesh set is not on this machine: python -m rail_mj.dataset real --out DIR and set "
                 "RAIL_MJ_REAL_DATA=DIR")
    os.environ["RAIL_MJ_MODEL"] = MODEL
    results = run(args.name, objects, args.relay, timeout=1800.0)  # a helper reads and answers in minutes
    with open(args.out, "a") as out:
        for case, r in zip(cases, results):
            out.write(json.dumps({"case": f"{args.name}::{case_name(case)}", "label": case["label"],
                                  "functional": r.functional, "probability": r.probability, "error": r.error,
                                  "definition": r.definition, "profile_check": r.profile_check,
                                  "llm_calls": r.llm_calls,
                                  "llm_repairs": r.llm_repairs}) + "\n")
    return 0


def use_of(exchange: dict[str, Any]) -> str:
    """The use an exchange was about: stage 0's and stage 7's name it, stages 1-6 in their task."""
    request = exchange["request"]
    return request["affordance"] if "affordance" in request else request["task"]["affordance"]


def relay_exchanges(relay: Path) -> list[dict[str, Any]]:
    """A relay folder's exchanges as the fixture keeps them: the stage's schema, request, attempt and answer."""
    from rail_mj.llm.relay import read_exchanges

    kept = []
    for e in read_exchanges(relay):
        body = {"messages": e["messages"]}
        kept.append({"schema": e["schema"], "request": request_payload(body), "attempt": attempt(body),
                     "answer": e["answer"]})
    return kept


def _keep(args: argparse.Namespace) -> int:
    kept = relay_exchanges(args.relay)
    lines = [line for path in args.results for line in Path(path).read_text().splitlines() if line.strip()]
    if args.only:  # the other uses keep what was recorded before
        kept = [e for e in exchanges() if use_of(e) not in args.only] + kept
        lines = [json.dumps(v) for k, v in verdicts().items() if k.split("::")[0] not in args.only] + lines
    (CORPUS / "exchanges.jsonl").write_text("".join(json.dumps(e) + "\n" for e in kept))
    (CORPUS / "verdicts.jsonl").write_text("\n".join(sorted(lines)) + "\n")
    print(f"kept {len(kept)} exchanges and {len(lines)} verdicts in {CORPUS}")
    return 0


if __name__ == "__main__":
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    sub = parser.add_subparsers(dest="command", required=True)
    rec = sub.add_parser("record", help="classify one use's cases through the relay")
    rec.add_argument("name", choices=sorted(CASES))
    rec.add_argument("--relay", required=True, help="the relay's base URL (…/v1)")
    rec.add_argument("--out", type=Path, required=True, help="append the verdicts here (JSON lines)")
    keep = sub.add_parser("keep", help="write the relay's exchanges and the verdicts into the fixture")
    keep.add_argument("relay", type=Path)
    keep.add_argument("results", nargs="+", type=Path)
    keep.add_argument("--only", nargs="+", choices=sorted(CASES), help="re-recorded uses: replace only theirs")
    parsed = parser.parse_args()
    sys.exit(_record(parsed) if parsed.command == "record" else _keep(parsed))
