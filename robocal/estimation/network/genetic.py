"""Genetic training of a :mod:`~robocal.estimation.network.mlp` network.

Chromosome
----------
An individual is one binary string: H structure bits (bit i = 1: hidden neuron i is active,
layer by layer) followed by W genes of B bits, one per weight or threshold in the order of
``Layout`` (θ).  A gene is the fixed-point code k ∈ {0, …, 2^B − 1} of a value in the bounded
range [−R, R]:

    value = −R + k · Δ,    Δ = 2R / (2^B − 1),    k = round((clip(value, −R, R) + R) / Δ),

written most significant bit first, so decode(encode(x)) = x to within Δ/2 inside the range.
The codes are kept as integers and the operators below act on them exactly as on the bits
(a mutation XORs one bit of a code); :meth:`Encoding.to_bits` / :meth:`Encoding.from_bits`
give the literal bit string.

Fitness
-------
With E the RMS error (mm) of the predicted Δp over the training poses, E₀ the RMS of Δp about
its mean (the error of predicting the mean), s the share of active hidden neurons and α = 0.95:

    fitness = 1 − α · E / E₀ − (1 − α) · s,

which grows as the error and the share of active neurons both fall; 1 would be a perfect fit
with no neuron at all, 1 − α − (1 − α)·s ≈ 0 means no better than the mean.

One generation (every sub-population at once, each on its own statistics)
--------------------------------------------------------------------------
1. Selection: binary tournaments (each parent is the fitter of two random individuals).
2. Crossover of parents (2i, 2i+1) with the adaptive probability of Srinivas and Patnaik,
   Pc = Pc1 − (Pc1 − Pc2)(y′ − ȳ)/(ymax − ȳ) if y′ ≥ ȳ, else Pc1 (y′ the larger fitness of
   the two parents, ȳ the mean and ymax the best fitness of the sub-population): arithmetic
   crossover with one λ ~ U(0, 1) per pair, children round(λa + (1 − λ)b) and
   round((1 − λ)a + λb) on the gene codes; on the structure bits its binary analogue,
   the first child taking each bit from a with probability λ and the second the other bit.
3. Mutation with Pm of the same form (Pm1, Pm2), y′ the fitness of the parent in the child's
   slot: each gene mutates with probability Pm by flipping one of its B bits chosen at
   random, each structure bit flips with probability Pm.
4. Elitism: the best individual of the previous generation replaces the worst child, so the
   best fitness never falls.
5. Migration (optional, ``migration_interval`` generations apart, off by default so the
   sub-populations stay independent): the best of sub-population j replaces the worst of
   sub-population j + 1 (a ring).

The run stops when the best fitness has risen by less than ``tolerance`` over the last
``window`` generations, or after ``generations``.
"""
import numpy as np

from .mlp import forward

PC1, PC2 = 0.9, 0.6
PM1, PM2 = 0.1, 0.01
ALPHA = 0.95
# The sizes (bits) of one gene that Encoding accepts; the network model checks its ``bits``
# setting against them so that a wrong value is reported before training starts.
MIN_BITS, MAX_BITS = 2, 30


class Encoding:
    """Fixed-point binary genes: ``bits`` bits over [−bound, bound] (see the module docstring)."""

    def __init__(self, bits=16, bound=4.0):
        if not MIN_BITS <= int(bits) <= MAX_BITS:
            raise ValueError(f"a gene needs between {MIN_BITS} and {MAX_BITS} bits")
        self.bits = int(bits)
        self.bound = float(bound)
        self.top = (1 << self.bits) - 1
        self.step = 2.0 * self.bound / self.top

    def encode(self, values):
        """Codes (int64) of ``values``; values outside the range are clipped to it."""
        values = np.clip(np.asarray(values, dtype=float), -self.bound, self.bound)
        return np.rint((values + self.bound) / self.step).astype(np.int64)

    def decode(self, codes, dtype=float):
        return (np.asarray(codes) * self.step - self.bound).astype(dtype)

    def to_bits(self, codes):
        """(…, G) codes → (…, G·bits) booleans, each gene most significant bit first."""
        codes = np.asarray(codes, dtype=np.int64)
        shifts = np.arange(self.bits - 1, -1, -1)
        return ((codes[..., None] >> shifts) & 1).astype(bool).reshape(codes.shape[:-1] + (-1,))

    def from_bits(self, bits):
        bits = np.asarray(bits, dtype=np.int64)
        groups = bits.reshape(bits.shape[:-1] + (-1, self.bits))
        return groups @ (1 << np.arange(self.bits - 1, -1, -1))


def chromosome(encoding, structure, codes):
    """The binary string of individuals: structure bits (…, H) then every gene's bits."""
    return np.concatenate([np.asarray(structure, dtype=bool), encoding.to_bits(codes)], axis=-1)


def adaptive_probability(y, y_mean, y_max, high, low):
    """Srinivas–Patnaik: ``high`` for y < ȳ, falling linearly to ``low`` at y = ymax.

    y: fitness of the individual (or the larger of a pair's); y_mean, y_max broadcast
    against it.  A sub-population whose fitness is all equal gets ``low`` (every y = ymax).
    """
    y, y_mean, y_max = np.broadcast_arrays(*(np.asarray(v, dtype=float) for v in (y, y_mean, y_max)))
    spread = y_max - y_mean
    above = np.divide(y - y_mean, spread, out=np.ones_like(y), where=spread > 0)
    return np.where(y >= y_mean, high - (high - low) * np.minimum(above, 1.0), high)


class Fitness:
    """fitness = 1 − α·E/E₀ − (1 − α)·s of a population, on standardised data.

    X (N, d) and Y (N, m) are standardised; ``scale`` (m,) turns an output's standardised
    error back into mm, so E is in mm.
    """

    def __init__(self, layout, X, Y, scale, alpha=ALPHA, dtype=np.float32):
        self.layout = layout
        self.X = np.asarray(X, dtype=dtype)
        self.Y = np.asarray(Y, dtype=dtype)
        self.weights = np.asarray(scale, dtype=dtype) ** 2
        self.alpha = float(alpha)
        self.dtype = dtype
        self.e0 = float(np.sqrt(np.mean(np.sum((Y - Y.mean(axis=0)) ** 2 * self.weights, axis=1))))
        if self.e0 == 0.0:
            raise ValueError("constant outputs: nothing to learn")

    def rms(self, theta, mask):
        """E (mm) of each individual: θ (P, W), mask (P, H) → (P,)."""
        residual = forward(self.layout, theta.astype(self.dtype, copy=False), mask, self.X)
        residual -= self.Y
        residual *= residual
        return np.sqrt(np.mean(residual @ self.weights, axis=1, dtype=np.float64))

    def __call__(self, theta, mask):
        share = np.asarray(mask, dtype=bool).mean(axis=-1) if self.layout.n_hidden else 0.0
        return 1.0 - self.alpha * self.rms(theta, mask) / self.e0 - (1.0 - self.alpha) * share


class GeneticAlgorithm:
    """The GA of the module docstring on ``fitness`` (a :class:`Fitness`).

    populations × population_size individuals; population_size must be even and ≥ 4.
    """

    def __init__(self, fitness, encoding=None, *, populations=4, population_size=30,
                 generations=300, tolerance=1e-5, window=50, migration_interval=None,
                 pc=(PC1, PC2), pm=(PM1, PM2), initial_active=0.9):
        self.fitness = fitness
        self.layout = fitness.layout
        self.encoding = encoding if encoding is not None else Encoding()
        self.populations = int(populations)
        self.population_size = int(population_size)
        if self.populations < 1 or self.population_size < 4 or self.population_size % 2:
            raise ValueError("need at least one sub-population of an even size >= 4")
        self.generations = int(generations)
        self.tolerance = float(tolerance)
        self.window = int(window)
        self.migration_interval = migration_interval
        self.pc, self.pm = pc, pm
        self.initial_active = float(initial_active)

    # ------------------------------------------------------------------ population
    def initial(self, rng):
        """Random structure (each neuron active with probability ``initial_active``) and
        genes from the network's own initialisation: (structure (S, M, H), codes (S, M, W))."""
        shape = (self.populations, self.population_size)
        structure = rng.random(shape + (self.layout.n_hidden,)) < self.initial_active
        theta = self.layout.initial(rng, np.prod(shape)).reshape(shape + (-1,))
        return structure, self.encoding.encode(theta)

    def evaluate(self, structure, codes):
        """Fitness (S, M) of every individual, in one batched forward pass."""
        S, M = structure.shape[:2]
        theta = self.encoding.decode(codes.reshape(S * M, -1), dtype=self.fitness.dtype)
        return self.fitness(theta, structure.reshape(S * M, -1)).reshape(S, M)

    # ------------------------------------------------------------------ operators
    def select(self, rng, fitness):
        """Binary tournament winners: (S, M) indices into each sub-population."""
        S, M = fitness.shape
        a, b = rng.integers(0, M, size=(2, S, M))
        rows = np.arange(S)[:, None]
        return np.where(fitness[rows, a] >= fitness[rows, b], a, b)

    def crossover(self, rng, structure, codes, fitness):
        """Adaptive arithmetic crossover of consecutive pairs; returns new arrays."""
        S, M = fitness.shape
        y_mean = fitness.mean(axis=1, keepdims=True)
        y_max = fitness.max(axis=1, keepdims=True)
        y_pair = np.maximum(fitness[:, 0::2], fitness[:, 1::2])  # (S, M/2)
        pc = adaptive_probability(y_pair, y_mean, y_max, *self.pc)
        cross = rng.random((S, M // 2)) < pc
        lam = np.where(cross, rng.random((S, M // 2)), 1.0)[..., None]  # λ = 1: copy
        a, b = codes[:, 0::2], codes[:, 1::2]
        out = np.empty_like(codes)
        out[:, 0::2] = np.rint(lam * a + (1.0 - lam) * b)
        out[:, 1::2] = np.rint((1.0 - lam) * a + lam * b)
        sa, sb = structure[:, 0::2], structure[:, 1::2]
        from_a = rng.random(sa.shape) < lam
        new_structure = np.empty_like(structure)
        new_structure[:, 0::2] = np.where(from_a, sa, sb)
        new_structure[:, 1::2] = np.where(from_a, sb, sa)
        return new_structure, out

    def mutate(self, rng, structure, codes, parent_fitness, fitness):
        """Adaptive mutation, in place: Pm from each child's parent fitness (S, M) against
        the statistics of the parents' sub-population ``fitness``."""
        pm = adaptive_probability(parent_fitness, fitness.mean(axis=1, keepdims=True),
                                  fitness.max(axis=1, keepdims=True), *self.pm)[..., None]
        hit = rng.random(codes.shape) < pm
        bit = rng.integers(0, self.encoding.bits, size=int(hit.sum()))
        codes[hit] ^= np.int64(1) << bit
        structure ^= rng.random(structure.shape) < pm

    def step(self, rng, structure, codes, fitness):
        """One generation: returns (structure, codes, fitness) of the next one."""
        S, M = fitness.shape
        rows = np.arange(S)[:, None]
        chosen = self.select(rng, fitness)
        parent_fitness = fitness[rows, chosen]
        new_structure, new_codes = self.crossover(rng, structure[rows, chosen], codes[rows, chosen],
                                                  parent_fitness)
        self.mutate(rng, new_structure, new_codes, parent_fitness, fitness)
        new_fitness = self.evaluate(new_structure, new_codes)
        # Elitism: the previous best takes the place of the worst child.
        best = np.argmax(fitness, axis=1)
        worst = np.argmin(new_fitness, axis=1)
        s = np.arange(S)
        new_structure[s, worst] = structure[s, best]
        new_codes[s, worst] = codes[s, best]
        new_fitness[s, worst] = fitness[s, best]
        return new_structure, new_codes, new_fitness

    def migrate(self, structure, codes, fitness):
        """Ring migration, in place: best of sub-population j → worst of j + 1."""
        S = fitness.shape[0]
        if S < 2:
            return
        s = np.arange(S)
        best = np.argmax(fitness, axis=1)
        target = (s + 1) % S
        worst = np.argmin(fitness, axis=1)[target]
        best_structure, best_codes, best_fitness = structure[s, best], codes[s, best], fitness[s, best]
        structure[target, worst] = best_structure
        codes[target, worst] = best_codes
        fitness[target, worst] = best_fitness

    # ------------------------------------------------------------------ run
    def run(self, rng, progress=None, initial=None):
        """Evolve from a random (or the given) population.

        Returns a dict: structure (H,) bool and codes (W,) of the best individual, theta (W,)
        its decoded weights, fitness, history (best fitness after each generation, the first
        entry being the initial population's), generations (run), stopped ("converged" or
        "generation limit").
        """
        structure, codes = self.initial(rng) if initial is None else initial
        fitness = self.evaluate(structure, codes)
        history = [float(fitness.max())]
        stopped = "generation limit"
        for generation in range(1, self.generations + 1):
            structure, codes, fitness = self.step(rng, structure, codes, fitness)
            if self.migration_interval and generation % self.migration_interval == 0:
                self.migrate(structure, codes, fitness)
            history.append(float(fitness.max()))
            if progress is not None:
                progress(generation, history[-1])
            if generation >= self.window and history[-1] - history[-1 - self.window] < self.tolerance:
                stopped = "converged"
                break
        s, m = np.unravel_index(np.argmax(fitness), fitness.shape)
        return {
            "structure": structure[s, m].copy(),
            "codes": codes[s, m].copy(),
            "theta": self.encoding.decode(codes[s, m]),
            "fitness": float(fitness[s, m]),
            "history": history,
            "generations": len(history) - 1,
            "stopped": stopped,
        }
