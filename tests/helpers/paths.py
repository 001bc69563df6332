"""Where the repository, the tests and their fixtures are, wherever a test module sits under tests/."""

from pathlib import Path

REPO = Path(__file__).resolve().parents[2]
FIXTURES = REPO / "tests" / "fixtures"
EXAMPLES = REPO / "examples"
