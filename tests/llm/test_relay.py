"""The recording relay (rail_mj.llm.relay): a request becomes a prompt file (its pictures PNG files beside it, named
where they stand), the answer file goes back as the completion, and the exchange is logged."""

from __future__ import annotations

import threading
import time
from pathlib import Path

from rail_mj.core.profile import CandidateInteraction, PoseCandidates, ResultSummary
from rail_mj.core.results import BasinInfo
from rail_mj.llm import FunctionalPoseRequest, OpenAIProvider, Picture, analyze_functional_poses
from rail_mj.llm.offline import offline_functional_poses
from rail_mj.llm.relay import RelayServer, read_exchanges

PNG = b"\x89PNG\r\n\x1a\n-a-picture"


def _request() -> FunctionalPoseRequest:
    summary = ResultSummary(frac_inside_bbox=0.9, frac_on_ground=0.0, frac_touching_object=0.8, mean_height=-0.4,
                            object_tilt_deg=1.0, agent_tilt_deg=5.0, agent_speed=0.0)
    return FunctionalPoseRequest(affordance="cup", expected_outcome="filled", poses=[PoseCandidates(
        pose_index=3, probability=0.7, half_extents=[0.04, 0.04, 0.05],
        basin=BasinInfo(rim=0.095, opening=[0.0, 0.0], length=0.07),
        candidates=[CandidateInteraction(plan="above", description="drop from above",
                                         via_poses=[[0.0, 0.0, 0.1], [0.0, 0.0, 0.06]], score=0.4, summary=summary)],
    )])


def test_a_request_and_its_pictures_become_files_and_the_answer_file_the_reply(tmp_path: Path) -> None:
    folder, request = tmp_path / "relay", _request()
    verdict = offline_functional_poses(request)

    def answer() -> None:  # whoever answers: here, the rules, once the prompt is there
        prompt = folder / "0001.prompt.md"
        for _ in range(200):
            if prompt.exists():
                (folder / "0001.answer.json").write_text(verdict.model_dump_json())
                return
            time.sleep(0.05)

    with RelayServer(folder, wait_s=30) as relay:
        helper = threading.Thread(target=answer)
        helper.start()
        provider = OpenAIProvider(base_url=relay.base_url, model="relayed", cache=False, http_retries=0, timeout=30)
        got = analyze_functional_poses(request, provider, [Picture("Picture of pose 3: above at its end", PNG,
                                                                   "pose 3")])
        helper.join()
    assert got == verdict
    prompt = (folder / "0001.prompt.md").read_text()
    assert "Picture of pose 3: above at its end\n\n[picture: the image file 0001-1.png]" in prompt
    assert (folder / "0001-1.png").read_bytes() == PNG and "FunctionalPoseVerdict" in prompt
    (logged,) = read_exchanges(folder)
    assert logged["schema"] == "FunctionalPoseVerdict" and logged["answer"] == verdict.model_dump_json()
