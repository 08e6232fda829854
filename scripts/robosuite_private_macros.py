"""Copy robosuite's macros.py to macros_private.py unless it exists (what robosuite's
scripts/setup_macros.py does, without its prompt and without importing robosuite)."""

import importlib.util
import shutil
from pathlib import Path

package = Path(importlib.util.find_spec("robosuite").origin).parent
private = package / "macros_private.py"
if not private.exists():
    shutil.copyfile(package / "macros.py", private)
