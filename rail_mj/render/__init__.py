"""Pictures, explanations and MuJoCo scenes of results: captioned renders, contact sheets, --explain, --save-scene."""
