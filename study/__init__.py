"""The thesis's study on mjx_skills: its report (`python -m study.report`), the verdicts on
the thesis's claims and the sections beyond the thesis, computed from the stored cells of
`experiments/*.toml`. Not part of the `mjx_skills` package, which never imports it; run it
from the repository's root."""
