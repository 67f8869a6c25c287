"""The relaxation, written once for every domain (Livesu 2018, section 3).

One module per step of the paper, in the order they run:

================  ===========================================================
module            step
================  ===========================================================
:mod:`.boundary`  the jagged boundary zeta, and the rows that hold phi to it
:mod:`.padding`   padding (section 4): split the elements whose heat is flat
:mod:`.heat`      1. heat diffuses from zeta, ``(M + t K) u = b``
:mod:`.field`     2. the unit field ``+-grad u / |grad u|`` that crosses zeta
:mod:`.smoothing` 3. the field averaged over neighbouring elements
:mod:`.integration` 4. least squares integrate the field into phi
:mod:`.result`    what a relaxation returns
:mod:`.relaxer`   :class:`Relaxer` runs the steps and keeps what calls share
:mod:`.oneshot`   :func:`relax`, its one-shot form
================  ===========================================================

The steps use only the domain protocol (:mod:`ndboundary.domains.base`), never the kind
of domain.
"""

from .boundary import Boundary
from .params import DEFAULT_LAM, DEFAULT_MU, DEFAULT_SMOOTHING, PAPER
from .oneshot import relax
from .relaxer import Relaxer
from .result import RelaxResult

__all__ = ["DEFAULT_LAM", "DEFAULT_MU", "DEFAULT_SMOOTHING", "PAPER", "Boundary", "RelaxResult", "Relaxer", "relax"]
