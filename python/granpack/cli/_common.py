"""What the commands share, under the names the command modules have used: the output
folder's lock, records and development options now live in `granpack._outputs`, beside
`granpack._console`, so that the paper's reproduction shares them without importing the
command."""

from .._outputs import *  # noqa: F403
from .._outputs import LOCK_NAME, RUN_FILES, RUN_FOLDERS  # noqa: F401
