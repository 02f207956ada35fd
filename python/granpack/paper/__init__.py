"""The paper's section 4 reproduced: examples 4.1-4.4 with rotations ON and OFF, its
tables 2-13 with the paper's numbers beside ours, the figures, the 2D mass study and the
report (``granpack paper`` on the command line).

```python
from granpack.paper import reproduce

report = reproduce("granpack-paper", quick=True)  # 2 packs per case, out/report.md
```

`reproduce` runs it all; `granpack.paper.report` writes the report and
`granpack.paper.mass2d` the comparison of the two 2D mass conventions. The tables are
`granpack.tables.paper_tables`, the paper's own numbers `granpack.tables.paper_values`
(``granpack/data/paper_tables.csv``).
"""

from .reproduction import PAPER_EXAMPLES, PAPER_PACKS, QUICK_PACKS, paper_phi, reproduce

__all__ = ["reproduce", "paper_phi", "PAPER_EXAMPLES", "PAPER_PACKS", "QUICK_PACKS"]
