#!/usr/bin/env python3
"""The peer for bench/narx_speed.sh: the same NARX as `panelbass identify narx`, trained with PyTorch.

Model (as panelbass): ŷ(k) = w₂·tanh(W₁·x(k) + b₁) + b₂ with x(k) = [y(k−1..k−na), u(k..k−nb)] on scaled data
(offset = mean, scale = max |x − mean| of the estimation part), samples before the record = 0. The parameters
are one flat θ in panelbass's layout (W₁ row-major, b₁, w₂, b₂), so a panelbass model file can be checked.
Initial weights follow the thesis's [5F] rule (uniform ±2/(#inputs + 1) per layer), drawn from torch's RNG.

Training:
  1. PEM warm start, as panelbass does: series-parallel (measured past outputs, one-step prediction error),
     full-batch LBFGS, early stopping on the validation simulation J (patience 20, ≤ 100 iterations).
  2. OEM from the PEM parameters with each optimizer in turn (Adam at two learning rates, LBFGS with a
     strong-Wolfe line search): parallel mode, BPTT through the whole free-run simulation of the estimation
     record from rest, loss = mean squared simulation error over k ≥ skip.
Each logged epoch (one Adam step, one LBFGS iteration) is followed by the validation J, computed exactly as
panelbass's training history does: free run from rest on the scaled validation data, [2A] over k ≥ skip.
An OEM run ends at its time budget, when its validation J reaches --target (if given), or after --patience
epochs without validation improvement. Every OEM run's clock starts at the end of the shared PEM phase,
i.e. its logged seconds include the PEM seconds, as if it had run PEM itself.

With --recipe ms instead (the multiple-shooting recipe of issue 59):
  1. Series-parallel Adam warm start: full-batch Adam (--adam-warm-lr) on the one-step prediction error for
     --adam-warm-epochs epochs, the validation J logged every --eval-every epochs, the best kept.
  2. Multiple-shooting L-BFGS from it: the estimation record from the skip on cut into windows of --ms-window
     samples (a remainder shorter than a window is left out), each window's initial output history (na values)
     a free parameter started at the measured outputs, all windows simulated at once as a batch; loss =
     (Σ e² + ρ·Σ ‖h_w − ŷ_{w−1}(end)‖²) / (2M), ρ = --ms-penalty; full-batch LBFGS with a strong-Wolfe line
     search until --budget or --patience epochs without validation improvement.
The validation J of every row is the free run with the first --init measured outputs setting the state, [2A]
over k ≥ init (--init 0: from rest, k ≥ skip), as panelbass's history with the same --init.

Output: a CSV with one row per epoch: run,epoch,seconds,J_val_pct (run = pem, adam-lr0.01, ..., lbfgs; with
--recipe ms: adam-sp, ms-lbfgs).
"""

import argparse
import csv
import math
import sys
import time
from typing import List

import numpy as np
import torch


def load_csv(path):
    """Columns u and y of a panelbass CSV (header u,y,...)."""
    with open(path, newline="") as f:
        rows = list(csv.DictReader(f))
    return np.array([float(r["u"]) for r in rows]), np.array([float(r["y"]) for r in rows])


def offset_and_scale(x):
    """panelbass's scaling: offset = mean, scale = max |x − mean|."""
    offset = x.mean()
    return offset, np.abs(x - offset).max()


def lagged(x, first_lag, count):
    """N×count matrix whose column j is x(k − first_lag − j), 0 before the record."""
    n = len(x)
    out = torch.zeros(n, count)
    for j in range(count):
        lag = first_lag + j
        out[lag:, j] = x[: n - lag] if lag > 0 else x
    return out


class Narx:
    """The NARX network on a flat θ (panelbass's layout) and its series-parallel and parallel outputs."""

    def __init__(self, na, nb, hidden):
        self.na, self.nb, self.hidden = na, nb, hidden
        self.inputs = na + nb + 1
        self.size = hidden * (self.inputs + 1) + hidden + 1

    def initial_theta(self, seed):
        """[5F]: first layer uniform ±2/(#inputs·1 + 1), output layer uniform ±2/(hidden + 1)."""
        gen = torch.Generator().manual_seed(seed)
        first = self.hidden * (self.inputs + 1)
        limits = torch.cat((torch.full((first,), 2.0 / (self.inputs + 1)),
                            torch.full((self.hidden + 1,), 2.0 / (self.hidden + 1))))
        return (2.0 * torch.rand(self.size, generator=gen) - 1.0) * limits

    def unpack(self, theta):
        h, i = self.hidden, self.inputs
        w1 = theta[: h * i].view(h, i)
        b1 = theta[h * i: h * (i + 1)]
        w2 = theta[h * (i + 1): h * (i + 2)]
        return w1, b1, w2, theta[-1]

    def predict(self, theta, y_past, u_lags):
        """PEM: ŷ(k) = F(y(k−1..k−na), u(k..k−nb)) with measured past outputs, all k at once."""
        w1, b1, w2, b2 = self.unpack(theta)
        return torch.tanh(torch.cat((y_past, u_lags), 1) @ w1.T + b1) @ w2 + b2

    def simulate(self, theta, u_lags, y_measured=None, init=0):
        """OEM: ŷ(k) = F(ŷ(k−1..k−na), u(k..k−nb)), free run from rest, or with ŷ(k) = y(k) for k < init (the
        measured outputs setting the state, as panelbass's --init); differentiable (BPTT)."""
        w1, b1, w2, b2 = self.unpack(theta)
        w_y = w1[:, : self.na]
        # The input part of every hidden node is known in advance: one matrix product for the record.
        # unbind, not pre[k]: indexing would make backward O(N²) (a full-size gradient per sample).
        pre = (u_lags @ w1[:, self.na:].T + b1).unbind(0)
        past = torch.zeros(self.na, dtype=theta.dtype)
        out: List[torch.Tensor] = []
        for k, pre_k in enumerate(pre):
            y = y_measured[k] if k < init else w2 @ torch.tanh(pre_k + w_y @ past) + b2
            out.append(y)
            past = torch.cat((y.view(1), past[:-1]))
        return torch.stack(out)

    def simulate_windows(self, theta, u_lags_windows, histories):
        """Multiple shooting: W windows at once, window w from its output history histories[w] = [ŷ(s−1..s−na)];
        u_lags_windows is W×T×(nb+1). Returns the W×T outputs."""
        w1, b1, w2, b2 = self.unpack(theta)
        w_y = w1[:, : self.na]
        pre = (u_lags_windows @ w1[:, self.na:].T + b1).unbind(1)  # T tensors of W×hidden
        past = histories
        out: List[torch.Tensor] = []
        for pre_t in pre:
            y = torch.tanh(pre_t + past @ w_y.T) @ w2 + b2
            out.append(y)
            past = torch.cat((y.view(-1, 1), past[:, :-1]), 1)
        return torch.stack(out, 1)


def j_percent(yhat, y, skip):
    """[2A] J = Σ(ŷ − y)² / Σy² in percent over k ≥ skip (inf if the simulation blew up)."""
    e = yhat[skip:] - y[skip:]
    j = 100.0 * float((e @ e) / (y[skip:] @ y[skip:]))
    return j if math.isfinite(j) else math.inf


class Log:
    """Rows run,epoch,seconds,J_val_pct, written as they come so a time-boxed run leaves a usable file."""

    def __init__(self, path):
        self.file = open(path, "w", newline="")
        self.writer = csv.writer(self.file, lineterminator="\n")
        self.writer.writerow(["run", "epoch", "seconds", "J_val_pct"])

    def add(self, run, epoch, seconds, j_val):
        self.writer.writerow([run, epoch, f"{seconds:.4f}", f"{j_val:.6g}"])
        self.file.flush()


class Best:
    """The lowest validation J so far, its θ, and the epochs since it last fell."""

    def __init__(self, j, theta):
        self.j, self.theta, self.since = j, theta.detach().clone(), 0

    def offer(self, j, theta):
        if j < self.j:
            self.j, self.theta, self.since = j, theta.detach().clone(), 0
        else:
            self.since += 1


def main():
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--data", required=True, help="panelbass CSV (columns u,y); first --est-rows rows estimate")
    p.add_argument("--est-rows", type=int, required=True)
    p.add_argument("--na", type=int, default=8)
    p.add_argument("--nb", type=int, default=8)
    p.add_argument("--hidden", type=int, default=17)
    p.add_argument("--skip", type=int, default=None, help="transient skip (default 2(na+nb), as panelbass)")
    p.add_argument("--seed", type=int, default=1)
    p.add_argument("--budget", type=float, default=600.0, help="wall seconds per OEM optimizer")
    p.add_argument("--patience", type=int, default=200, help="OEM epochs without validation improvement")
    p.add_argument("--target", type=float, default=None, help="stop an OEM run once its J_val %% ≤ this")
    p.add_argument("--adam-lr", default="1e-2,3e-3", help="Adam learning rates to try")
    p.add_argument("--check-model", help="panelbass model JSON: print its validation J by this script's code")
    p.add_argument("--init", type=int, default=0,
                   help="measured outputs that set the state of every validation free run (panelbass's --init); "
                        "J over k ≥ init (0: from rest, k ≥ skip)")
    p.add_argument("--recipe", choices=("bptt", "ms"), default="bptt",
                   help="bptt: PEM LBFGS then OEM Adam/LBFGS through the whole record; ms: series-parallel Adam, "
                        "then multiple-shooting LBFGS")
    p.add_argument("--adam-warm-lr", type=float, default=1e-2, help="ms: learning rate of the series-parallel Adam")
    p.add_argument("--adam-warm-epochs", type=int, default=2000, help="ms: full-batch series-parallel Adam epochs")
    p.add_argument("--eval-every", type=int, default=50, help="ms: Adam epochs between validation J figures")
    p.add_argument("--ms-window", type=int, default=250, help="ms: samples per window")
    p.add_argument("--ms-penalty", type=float, default=1.0, help="ms: continuity penalty ρ")
    p.add_argument("--out", required=True, help="CSV log")
    p.add_argument("--threads", type=int, default=1,
                   help="torch threads (1, as panelbass trains on one core; on a shared machine 2 threads spin "
                        "against the load: a series-parallel epoch took 56 ms with 2, 3 ms with 1)")
    a = p.parse_args()

    torch.set_num_threads(a.threads)
    torch.set_default_dtype(torch.float64)
    skip = a.skip if a.skip is not None else 2 * (a.na + a.nb)

    u_all, y_all = load_csv(a.data)
    n = a.est_rows
    u_off, u_scale = offset_and_scale(u_all[:n])
    y_off, y_scale = offset_and_scale(y_all[:n])
    us = torch.from_numpy((u_all - u_off) / u_scale)
    ys = torch.from_numpy((y_all - y_off) / y_scale)
    u_est, y_est, u_val, y_val = us[:n], ys[:n], us[n:], ys[n:]
    ulags_est, ulags_val = lagged(u_est, 0, a.nb + 1), lagged(u_val, 0, a.nb + 1)
    ypast_est = lagged(y_est, 1, a.na)
    net = Narx(a.na, a.nb, a.hidden)

    j_from = a.init if a.init > 0 else skip

    def j_val(theta):
        with torch.no_grad():
            return j_percent(net.simulate(theta, ulags_val, y_val, a.init), y_val, j_from)

    if a.check_model:
        import json
        with open(a.check_model) as f:
            model = json.load(f)
        theta = torch.tensor(model["params"]["theta"])
        print(f"check: {a.check_model}: J_val {j_val(theta):.6g} % (free run, init {a.init}, k ≥ {j_from})",
              file=sys.stderr)

    log = Log(a.out)
    if a.recipe == "ms":
        multiple_shooting_recipe(a, net, skip, u_est, y_est, ypast_est, ulags_est, j_val, log)
        return

    # 1. PEM warm start: full-batch LBFGS on the one-step prediction error, early stopping on J_val.
    started = time.perf_counter()
    theta = net.initial_theta(a.seed).requires_grad_()
    pem = torch.optim.LBFGS([theta], lr=1.0, max_iter=1, line_search_fn="strong_wolfe")

    def pem_loss():
        pem.zero_grad()
        loss = ((net.predict(theta, ypast_est, ulags_est) - y_est)[skip:] ** 2).mean()
        loss.backward()
        return loss

    best_j, best_theta, since_best = j_val(theta.detach()), theta.detach().clone(), 0
    log.add("pem", 0, time.perf_counter() - started, best_j)
    for epoch in range(1, 101):
        pem.step(pem_loss)
        j = j_val(theta.detach())
        log.add("pem", epoch, time.perf_counter() - started, j)
        if j < best_j:
            best_j, best_theta, since_best = j, theta.detach().clone(), 0
        else:
            since_best += 1
            if since_best >= 20:
                break
    pem_seconds = time.perf_counter() - started
    theta_pem, j_pem = best_theta, best_j
    print(f"pem: J_val {j_pem:.4g} % after {pem_seconds:.1f} s", file=sys.stderr)

    # 2. OEM by BPTT through the free-run simulation, each optimizer from the PEM parameters.
    def oem_run(name, make_optimizer, closure_style):
        theta = theta_pem.clone().requires_grad_()
        opt = make_optimizer(theta)

        def loss_fn():
            opt.zero_grad()
            loss = ((net.simulate(theta, ulags_est) - y_est)[skip:] ** 2).mean()
            loss.backward()
            return loss

        best_j, best_theta, since_best, epoch = j_pem, theta_pem.clone(), 0, 0
        started = time.perf_counter() - pem_seconds
        log.add(name, 0, pem_seconds, j_pem)
        while time.perf_counter() - started - pem_seconds < a.budget:
            epoch += 1
            if closure_style:
                opt.step(loss_fn)
            else:
                loss_fn()
                opt.step()
            if not torch.isfinite(theta).all():  # a diverged step: keep the best so far and end the run
                print(f"{name}: parameters became non-finite at epoch {epoch}; run ended", file=sys.stderr)
                break
            j = j_val(theta.detach())
            log.add(name, epoch, time.perf_counter() - started, j)
            if j < best_j:
                best_j, best_theta, since_best = j, theta.detach().clone(), 0
            else:
                since_best += 1
            if (a.target is not None and best_j <= a.target) or since_best >= a.patience:
                break
        print(f"{name}: best J_val {best_j:.4g} % in {epoch} epochs, {time.perf_counter() - started:.1f} s",
              file=sys.stderr)

    for lr in (float(x) for x in a.adam_lr.split(",") if x):
        oem_run(f"adam-lr{lr:g}", lambda th, lr=lr: torch.optim.Adam([th], lr=lr), closure_style=False)
    oem_run("lbfgs", lambda th: torch.optim.LBFGS([th], lr=1.0, max_iter=1, history_size=20,
                                                  line_search_fn="strong_wolfe"), closure_style=True)


def multiple_shooting_recipe(a, net, skip, u_est, y_est, ypast_est, ulags_est, j_val, log):
    """Series-parallel Adam, then multiple-shooting LBFGS (see the module's doc); rows adam-sp and ms-lbfgs, the
    clock running on from the start of the Adam phase."""
    started = time.perf_counter()
    theta = net.initial_theta(a.seed).requires_grad_()
    adam = torch.optim.Adam([theta], lr=a.adam_warm_lr)
    best = Best(j_val(theta.detach()), theta)
    log.add("adam-sp", 0, time.perf_counter() - started, best.j)
    for epoch in range(1, a.adam_warm_epochs + 1):
        adam.zero_grad()
        loss = ((net.predict(theta, ypast_est, ulags_est) - y_est)[skip:] ** 2).mean()
        loss.backward()
        adam.step()
        if epoch % a.eval_every == 0 or epoch == a.adam_warm_epochs:
            j = j_val(theta.detach())
            log.add("adam-sp", epoch, time.perf_counter() - started, j)
            best.offer(j, theta)
    print(f"adam-sp: J_val {best.j:.4g} % after {time.perf_counter() - started:.1f} s", file=sys.stderr)

    # windows over [skip, skip + W·T)
    T = a.ms_window
    W = (len(y_est) - skip) // T
    if W < 1:
        raise SystemExit(f"--ms-window {T} is longer than the estimation record after the skip")
    starts = [skip + w * T for w in range(W)]
    u_windows = torch.stack([ulags_est[s: s + T] for s in starts])          # W×T×(nb+1)
    y_windows = torch.stack([y_est[s: s + T] for s in starts])              # W×T
    histories = torch.stack([ypast_est[s] for s in starts]).clone().requires_grad_()  # W×na: y(s−1..s−na)
    theta = best.theta.clone().requires_grad_()
    M = W * T
    opt = torch.optim.LBFGS([theta, histories], lr=1.0, max_iter=1, history_size=20, line_search_fn="strong_wolfe")

    def ms_loss():
        opt.zero_grad()
        sim = net.simulate_windows(theta, u_windows, histories)
        ends = torch.flip(sim[:-1, -net.na:], (1,))  # ŷ(s_w−1..s_w−na) of each window's predecessor
        loss = (((sim - y_windows) ** 2).sum() + a.ms_penalty * ((histories[1:] - ends) ** 2).sum()) / (2 * M)
        loss.backward()
        return loss

    best.since, epoch = 0, 0
    log.add("ms-lbfgs", 0, time.perf_counter() - started, best.j)
    while time.perf_counter() - started < a.budget:
        epoch += 1
        opt.step(ms_loss)
        if not torch.isfinite(theta).all():
            print(f"ms-lbfgs: parameters became non-finite at epoch {epoch}; run ended", file=sys.stderr)
            break
        j = j_val(theta.detach())
        log.add("ms-lbfgs", epoch, time.perf_counter() - started, j)
        best.offer(j, theta)
        if (a.target is not None and best.j <= a.target) or best.since >= a.patience:
            break
    print(f"ms-lbfgs: best J_val {best.j:.4g} % in {epoch} epochs, {time.perf_counter() - started:.1f} s",
          file=sys.stderr)


if __name__ == "__main__":
    main()
