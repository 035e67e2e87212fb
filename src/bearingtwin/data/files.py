"""The readers of every file format under the name the guide once gave them (``from bearingtwin.data.files import
load_recording``): scripts written to it keep running, warned to import from :mod:`bearingtwin.data.formats`."""

import warnings

from bearingtwin.data.formats import *  # noqa: F401,F403  (the public names, as formats defines them)

warnings.warn("bearingtwin.data.files is now bearingtwin.data.formats: import load_recording and the other readers "
              "from there", DeprecationWarning, stacklevel=2)
