"""Random-effects Bayesian model selection across participants (Stephan et al. 2009; Rigoux et al. 2014).

Each participant's answers come from one of K models, participant i's from model m with probability r_m
(the models' frequencies in the population, r ~ Dirichlet(α0)).  Given every participant's log evidence
L[m, i] under every model, the variational posterior is r ~ Dirichlet(α) with

    z[m, i] ∝ exp(L[m, i] + ψ(α_m) - ψ(Σ α))      (who came from which model)
    α = α0 + Σ_i z[:, i]

iterated to convergence (Rigoux et al. 2014, eq. A21).  The *exceedance probability* of model m is
P(r_m > r_j for every j ≠ m) under Dirichlet(α), computed by one-dimensional quadrature (Soch & Allefeld
2016, eq. 14); the *protected* exceedance probability weighs it against the hypothesis that every
model is equally frequent (the Bayesian omnibus risk, BOR: Rigoux et al. 2014, eq. 7).
tests/teaching/core/test_bms.py checks all of it against the groupBMC package and by hand.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy import integrate
from scipy.special import digamma, gammainc, gammaln, logsumexp, softmax


@dataclass(frozen=True)
class BMSResult:
    """alpha (K,): the posterior Dirichlet's parameters; frequency (K,) its mean; attribution (K, P):
    P(participant i came from model m); exceedance (K,); protected_exceedance (K,); bor: the Bayesian
    omnibus risk (probability that the models are all equally frequent)."""

    alpha: np.ndarray
    frequency: np.ndarray
    attribution: np.ndarray
    exceedance: np.ndarray
    protected_exceedance: np.ndarray
    bor: float


def exceedance(alpha: np.ndarray) -> np.ndarray:
    """(K,) P(r_m is the largest) for r ~ Dirichlet(alpha): with r_m = g_m / Σ g, g_m ~ Gamma(α_m),
    P(g_m > g_j ∀ j) = ∫ p(g_m = x) Π_{j≠m} P(g_j < x) dx."""
    alpha = np.asarray(alpha, np.float64)
    out = np.empty(len(alpha))
    for m, a in enumerate(alpha):
        others = np.delete(alpha, m)

        def density(x, a=a, others=others):
            if x <= 0:
                return 0.0
            return float(np.exp((a - 1) * np.log(x) - x - gammaln(a)) * np.prod(gammainc(others, x)))

        hi = a + 40 * np.sqrt(a) + 40  # past every mass of Gamma(a)
        out[m] = integrate.quad(density, 0, hi, limit=200, points=[max(a - 1, 0.0)])[0]
    return out / out.sum()


def _free_energy(log_ev: np.ndarray, alpha0: np.ndarray, alpha: np.ndarray, z: np.ndarray) -> float:
    """F1: the variational lower bound of log p(data | H1), Rigoux et al. 2014 eq. A20."""
    e_log_r = digamma(alpha) - digamma(alpha.sum())
    tiny = np.finfo(float).tiny
    # a ruled-out model (log evidence -inf) has z = 0: its term is 0, not 0 * -inf
    weighted = np.zeros_like(z)
    np.multiply(z, log_ev + e_log_r[:, None], out=weighted, where=z > 0)
    joint = weighted.sum() + ((alpha0 - 1) * e_log_r).sum()
    joint += gammaln(alpha0.sum()) - gammaln(alpha0).sum()
    entropy_z = -(z * np.log(z + tiny)).sum()
    entropy_r = gammaln(alpha).sum() - gammaln(alpha.sum()) - ((alpha - 1) * e_log_r).sum()
    return float(joint + entropy_z + entropy_r)


def _null_free_energy(log_ev: np.ndarray, alpha0: np.ndarray) -> float:
    """F0: log p(data | H0), every model equally frequent (r = α0 / Σ α0), eq. A17."""
    return float(logsumexp(log_ev + np.log(alpha0 / alpha0.sum())[:, None], axis=0).sum())


def random_effects_bms(log_evidence: np.ndarray, alpha0: np.ndarray | None = None, *, tol: float = 1e-8,
                       max_iter: int = 1000) -> BMSResult:
    """log_evidence: (K models, P participants) log p(answers of i | model m), -inf where model m rules
    participant i's answers out.  alpha0: (K,) prior (default 1 each).  Returns :class:`BMSResult`."""
    log_ev = np.asarray(log_evidence, np.float64)
    if log_ev.ndim != 2 or log_ev.shape[0] < 2 or log_ev.shape[1] < 1:
        raise ValueError("model selection needs log evidence for at least 2 models and 1 participant")
    if np.isnan(log_ev).any() or np.isposinf(log_ev).any() or not np.isfinite(log_ev).any(0).all():
        raise ValueError("every participant needs a finite log evidence under some model (-inf: a model that "
                         "rules their answers out)")
    alpha0 = np.ones(log_ev.shape[0]) if alpha0 is None else np.asarray(alpha0, np.float64)
    alpha = alpha0.copy()
    for _ in range(max_iter):
        z = softmax(log_ev + (digamma(alpha) - digamma(alpha.sum()))[:, None], axis=0)
        new = alpha0 + z.sum(1)
        done = np.abs(new - alpha).max() < tol
        alpha = new
        if done:
            break
    f1 = _free_energy(log_ev, alpha0, alpha, z)
    f0 = _null_free_energy(log_ev, alpha0)
    bor = float(1 / (1 + np.exp(np.clip(f1 - f0, -700, 700))))
    ep = exceedance(alpha)
    return BMSResult(alpha=alpha, frequency=alpha / alpha.sum(), attribution=z, exceedance=ep,
                     protected_exceedance=ep * (1 - bor) + bor / len(alpha), bor=bor)
