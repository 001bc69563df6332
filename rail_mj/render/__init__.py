"""Pictures and explanations of results: captioned renders, contact sheets, ``--explain``."""
