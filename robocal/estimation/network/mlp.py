"""A multilayer perceptron whose hidden neurons can be switched off, for one network or a
whole population of them at once.

Layers: inputs (d) → hidden layers (h₁, …, h_k, tanh) → outputs (m, linear).  Each layer l
computes a_l = tanh(a_{l−1} W_l + b_l) ∘ s_l, where s_l ∈ {0, 1}^{h_l} says which of its
neurons are active: an inactive neuron outputs 0, exactly as if it had been removed together
with its weights.

All weights and thresholds (biases) of one network live in one flat vector θ, layer by layer,
each layer's W_l (in × out, row-major) followed by b_l.  A population is θ of shape (P, W)
with masks (P, H), H = Σ h_l; its forward pass is a handful of batched matrix products
(P, N, in) @ (P, in, out) — no Python loop over individuals or points.
"""
import numpy as np

# OpenBLAS runs a matrix product on several threads once rows × inner × columns exceeds
# 4 · 65536, and its idle threads then spin.  numpy and scipy each load their own OpenBLAS,
# so an L-BFGS loop that alternates between them keeps two spinning pools fighting the main
# thread for the cores: measured on 2 cores, 6 to 10 times slower than single-threaded
# products, which are as fast at these sizes.  Products are therefore cut into row blocks
# below that size.
SINGLE_THREAD_PRODUCT = 4 * 65536


class Layout:
    """Sizes of a network and where each layer's weights sit in the flat vector θ."""

    def __init__(self, n_inputs, hidden, n_outputs):
        self.sizes = (int(n_inputs),) + tuple(int(h) for h in hidden) + (int(n_outputs),)
        self.hidden = self.sizes[1:-1]
        self.slices = []  # per layer: (slice of W, slice of b)
        start = 0
        for fan_in, fan_out in zip(self.sizes[:-1], self.sizes[1:]):
            w = slice(start, start + fan_in * fan_out)
            b = slice(w.stop, w.stop + fan_out)
            self.slices.append((w, b))
            start = b.stop
        self.n_weights = start
        bounds = np.cumsum((0,) + self.hidden)
        self.mask_slices = [slice(a, b) for a, b in zip(bounds[:-1], bounds[1:])]
        self.n_hidden = int(bounds[-1])

    def unpack(self, theta):
        """[(W_l (…, in, out), b_l (…, out))] as views of θ (…, n_weights)."""
        lead = theta.shape[:-1]
        return [(theta[..., w].reshape(lead + (fan_in, fan_out)), theta[..., b])
                for (w, b), fan_in, fan_out in zip(self.slices, self.sizes[:-1], self.sizes[1:])]

    def active_weights(self, mask):
        """Number of weights and thresholds that act with the hidden neurons ``mask`` (H,) on."""
        mask = np.asarray(mask, dtype=bool)
        active = [np.ones(self.sizes[0], dtype=bool)] + [mask[s] for s in self.mask_slices] \
            + [np.ones(self.sizes[-1], dtype=bool)]
        return int(sum(a_in.sum() * a_out.sum() + a_out.sum()
                       for a_in, a_out in zip(active[:-1], active[1:])))

    def initial(self, rng, count=None):
        """Random θ (count, W) or (W,): weights N(0, 1/fan_in) (the tanh units start in their
        linear range on standardised inputs), thresholds 0."""
        shape = () if count is None else (int(count),)
        theta = np.zeros(shape + (self.n_weights,))
        for (w, _), fan_in in zip(self.slices, self.sizes[:-1]):
            theta[..., w] = rng.normal(scale=1.0 / np.sqrt(fan_in), size=shape + (w.stop - w.start,))
        return theta


def _block_rows(inner, columns):
    return max(1, SINGLE_THREAD_PRODUCT // max(1, inner * columns))


def matmul(a, b):
    """a @ b for a (…, N, k) and b (…, k, m), in row blocks that BLAS keeps on one thread."""
    rows = _block_rows(a.shape[-1], b.shape[-1])
    if a.shape[-2] <= rows:
        return np.matmul(a, b)
    shape = np.broadcast_shapes(a.shape[:-2], b.shape[:-2]) + (a.shape[-2], b.shape[-1])
    out = np.empty(shape, dtype=np.result_type(a, b))
    for start in range(0, a.shape[-2], rows):
        np.matmul(a[..., start:start + rows, :], b, out=out[..., start:start + rows, :])
    return out


def matmul_transposed(a, b):
    """aᵀ @ b for a (N, k) and b (N, m), summed over row blocks (see :func:`matmul`)."""
    rows = _block_rows(a.shape[1], b.shape[1])
    out = a[:rows].T @ b[:rows]
    for start in range(rows, len(a), rows):
        out += a[start:start + rows].T @ b[start:start + rows]
    return out


def forward(layout, theta, mask, X):
    """Outputs of a population: θ (P, W), masks (P, H), X (N, d) → (P, N, m).

    Works in the dtype of θ (float32 halves the time of a GA generation).
    """
    a = X.astype(theta.dtype, copy=False)
    layers = layout.unpack(theta)
    mask = mask.astype(theta.dtype, copy=False)
    for (W, b), s in zip(layers[:-1], layout.mask_slices):
        z = matmul(a, W)  # (N, in) or (P, N, in) @ (P, in, out)
        z += b[:, None, :]
        a = np.tanh(z, out=z)
        a *= mask[:, None, s]
    W, b = layers[-1]
    out = matmul(a, W)
    out += b[:, None, :]
    return out


def forward_one(layout, theta, mask, X):
    """Outputs of one network: θ (W,), mask (H,), X (N, d) → (N, m)."""
    return forward(layout, theta[None], np.asarray(mask)[None], X)[0]


def loss_and_gradient(layout, theta, mask, X, Y, weights):
    """L = Σ_n Σ_j w_j (ŷ_nj − y_nj)² and dL/dθ, by backpropagation through the active neurons.

    Inactive neurons output 0, so the weights into and out of them get a zero gradient and
    stay where they are.
    """
    layers = layout.unpack(theta)
    masks = [np.asarray(mask, dtype=float)[s] for s in layout.mask_slices]
    activations = [X]
    for (W, b), s in zip(layers[:-1], masks):
        activations.append(np.tanh(matmul(activations[-1], W) + b) * s)
    W, b = layers[-1]
    residual = matmul(activations[-1], W) + b - Y
    weighted = residual * weights
    loss = float(np.sum(weighted * residual))
    gradient = np.empty_like(theta)
    delta = 2.0 * weighted  # dL/d(pre-activation) of the current layer
    for index in range(len(layers) - 1, -1, -1):
        W, _ = layers[index]
        w_slice, b_slice = layout.slices[index]
        a_in = activations[index]
        gradient[w_slice] = matmul_transposed(a_in, delta).ravel()
        gradient[b_slice] = delta.sum(axis=0)
        if index:
            # a = tanh(z)·s with s ∈ {0, 1}, so da/dz = (1 − a²)·s.
            s = masks[index - 1]
            delta = matmul(delta, W.T) * (1.0 - a_in * a_in) * s
    return loss, gradient
