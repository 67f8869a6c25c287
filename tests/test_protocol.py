"""A domain kind defined outside the package, through the public protocol only, relaxes."""

import numpy as np
import pytest
import scipy.sparse as sp

from ndboundary import Domain, Relaxer, relax


class IntervalChain(Domain):
    """Segments between consecutive points of a line: a domain built from the protocol alone."""

    def __init__(self, x):
        self.points = np.asarray(x, dtype=np.float64).reshape(-1, 1)

    @property
    def n_elements(self):
        return self.n_vertices - 1

    @property
    def element_dim(self):
        return 1

    def _lengths(self):
        return np.diff(self.points[:, 0])

    def build_gradient(self):
        e = np.arange(self.n_elements)
        inv = 1.0 / self._lengths()
        return sp.csr_matrix(
            (np.r_[-inv, inv], (np.r_[e, e], np.r_[e, e + 1])), shape=(self.n_elements, self.n_vertices)
        )

    def build_measures(self):
        return self._lengths()

    def build_mass(self):
        half = 0.5 * self._lengths()
        return np.r_[half, 0.0] + np.r_[0.0, half]

    def build_incidence(self):
        e = np.arange(self.n_elements)
        return sp.csr_matrix((np.ones(2 * e.size), (np.r_[e, e + 1], np.r_[e, e])), shape=(self.n_vertices, self.n_elements))

    def build_adjacency(self):
        n = self.n_elements
        return sp.diags([np.ones(n - 1), np.ones(n - 1)], [-1, 1], shape=(n, n))

    def build_edges(self):
        e = np.arange(self.n_elements)
        return np.stack([e, e + 1], axis=1)

    def element_centroids(self):
        return 0.5 * (self.points[:-1] + self.points[1:])

    def simplicial_refinement(self):
        return self.points, self.build_edges(), None


@pytest.fixture
def chain():
    x = np.sort(np.random.default_rng(0).uniform(0, 1, 200))
    return IntervalChain(np.r_[0.0, x, 1.0])


def test_new_domain_relaxes_through_the_protocol(chain):
    labels = (chain.element_centroids()[:, 0] > 0.4).astype(int)
    res = relax(chain, labels, on="elements")
    assert np.all(np.diff(res.phi) > -1e-9)  # phi grows from region 0 into region 1
    point = res.level_set()
    assert point.n_points == 1
    jump = chain.points[res.boundary.sources, 0]
    assert abs(point.points[0, 0] - jump[0]) < 0.5 * chain.mean_edge_length()
    # the default stiffness is the consistent G^T diag(A) G, and the identities hold
    assert abs(chain.K @ np.ones(chain.n_vertices)).max() < 1e-9
    np.testing.assert_allclose(chain.div(chain.gradient(chain.points[:, 0] ** 2)), chain.K @ chain.points[:, 0] ** 2)


def test_new_domain_gets_the_relaxer(chain):
    labels = (chain.element_centroids()[:, 0] > 0.6).astype(int)
    relaxer = Relaxer(chain)
    np.testing.assert_array_equal(relaxer.relax(labels, on="elements").phi, relax(chain, labels, on="elements").phi)


def test_padding_needs_the_domain_to_split(chain):
    labels = np.zeros(chain.n_elements, dtype=int)
    labels[100] = 1  # one element between two boundary vertices: flat heat
    with pytest.raises(NotImplementedError, match="pad=False"):
        relax(chain, labels, on="elements")
    assert np.all(np.isfinite(relax(chain, labels, on="elements", pad=False).phi))
