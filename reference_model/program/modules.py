"""The torch modules every program model shares: object perception, the splitter, and
the interface of a step model (what NSRM and NMN+ each define)."""

from __future__ import annotations

from abc import ABCMeta, abstractmethod
from collections.abc import Mapping, Sequence
from typing import Any

import torch
import torch.nn.functional as F
from torch import Tensor, nn

from nsrmp_bench.reference_model.features import CropEncoder
from nsrmp_bench.reference_model.program.scene3d import ActionRule
from nsrmp_bench.reference_model.tokens import PAD

__all__ = ["Perception", "ProgramModel", "Splitter", "StepModel", "StepOutput", "TokenEncoder",
           "pad_tokens"]

_SIZE_MEAN, _SIZE_SCALE = 0.08, 0.01  # metres: objects here are 5-7 cm

StepOutput = tuple[Tensor, Tensor, Tensor]
"""Log-probabilities of the subject (R, N), the base (R, N) and the action (R, 3)."""


class Perception(nn.Module):
    """Object crops (B, N, 3, C, C) and sizes (B, N, 2) -> features (B, N, dim); trained
    to the end (D6).

    A crop is resized to a square, so it has lost how big the object is; with
    ``sizes`` the head also reads each object's estimated width and height in metres
    (:class:`~.scene3d.SceneState`): a lego brick is a third larger than a cube, which
    the crop alone confused it with (cube/lego were most of the attribute-only
    grounding misses)."""

    def __init__(self, dim: int, sizes: bool = False, augment: bool = False) -> None:
        super().__init__()
        self.cnn = CropEncoder(48)
        self.sizes = sizes
        self.augment = augment
        self.head = nn.Sequential(nn.Linear(self.cnn.out_dim + (2 if sizes else 0), 64),
                                  nn.ReLU(), nn.Linear(64, dim))
        self.dim = dim

    def forward(self, crops: Tensor, mask: Tensor, sizes: Tensor) -> Tensor:
        b, n = mask.shape
        flat = mask.reshape(-1)
        out = crops.new_zeros((b * n, self.dim), dtype=torch.float32)
        if bool(flat.any()):
            c = crops.reshape(b * n, *crops.shape[2:])[flat]
            x = self.cnn(_jitter(c) if self.augment and self.training else c)
            if self.sizes:
                x = torch.cat([x, (sizes.reshape(b * n, 2)[flat] - _SIZE_MEAN) / _SIZE_SCALE],
                              -1)
            out[flat] = self.head(x)
        return out.reshape(b, n, self.dim)


def pad_tokens(rows: Sequence[Sequence[int]]) -> Tensor:
    """PAD-padded (len(rows), T) tokens."""
    t = max(1, max((len(r) for r in rows), default=1))
    out = torch.full((len(rows), t), PAD, dtype=torch.long)
    for i, r in enumerate(rows):
        out[i, : len(r)] = torch.tensor(list(r), dtype=torch.long)
    return out


def _jitter(crops: Tensor) -> Tensor:
    """Crops (K, 3, C, C) each shifted by up to a tenth of its size and scaled by 0.9-1.1
    (torch's generator: the run's seed), as a box drawn a little differently would crop
    it; float, the values of the uint8 range."""
    k = crops.shape[0]
    scale = 0.9 + 0.2 * torch.rand(k)
    shift = 0.2 * torch.rand(k, 2) - 0.1
    theta = torch.zeros(k, 2, 3)
    theta[:, 0, 0] = scale
    theta[:, 1, 1] = scale
    theta[:, :, 2] = shift
    grid = F.affine_grid(theta, list(crops.shape), align_corners=False)
    out: Tensor = F.grid_sample(crops.float(), grid, padding_mode="border",
                                align_corners=False)
    return out


class TokenEncoder(nn.Module):
    """Tokens (B, T) -> contextual states (B, T, dim): two convolutions read word order
    (a window of 13 tokens), one self-attention layer the whole sequence. Parallel over
    tokens, so it trains fast on a CPU (a GRU was 10x slower here)."""

    def __init__(self, vocab_size: int, dim: int = 64) -> None:
        super().__init__()
        self.embed = nn.Embedding(vocab_size, dim, padding_idx=PAD)
        self.conv1 = nn.Conv1d(dim, dim, 5, padding=2)
        self.conv2 = nn.Conv1d(dim, dim, 5, padding=4, dilation=2)
        self.attend = nn.TransformerEncoderLayer(dim, 4, 2 * dim, dropout=0.0,
                                                 batch_first=True)
        self.dim = dim

    def forward(self, tokens: Tensor) -> Tensor:
        pad = tokens == PAD
        x = self.embed(tokens)
        keep = (~pad)[..., None].float()
        h = x + torch.relu(self.conv1((x * keep).transpose(1, 2))).transpose(1, 2)
        h = h + torch.relu(self.conv2((h * keep).transpose(1, 2))).transpose(1, 2)
        out: Tensor = self.attend(h * keep, src_key_padding_mask=pad)
        return out


class Splitter(nn.Module):
    """Where an instruction breaks into steps: for each token t >= 1, the log-odds that a
    new step starts at it, read from the whole instruction.

    Its teacher spreads each boundary's probability over the few places where the steps
    read the same, so a boundary is a *peak*: the most probable token once the ``gap``
    tokens either side of the peaks already taken are set aside, with the probability
    mass of the ``WINDOW`` tokens either side of it (:meth:`peaks`). ``gap`` is the
    fewest tokens a step can have, less one: two peaks closer than that are two places
    of one boundary, not two steps. With ``gap`` 3 (= ``WINDOW``, checkpoints from before
    it) a boundary whose mass the teacher spread 4-5 tokens apart, between a
    reference's inner "and" ("... that is white and | is a lego , after | that ...": the
    steps read the same cut at either) and the connector, was cut twice: 7 of the 9
    paper-v2/test instructions cut into a wrong number of steps by the checkpoint before.
    Where the steps start (:meth:`cuts`):

    - ``threshold`` t >= 0: at every peak whose mass reaches t. Each boundary is then
      decided where it is, so an instruction of seven steps is cut as one of two is (its
      peaks hold 0.5-0.75 against 0.1 for the next, measured on a 3-7 step part).
      Training fits t on training episodes (:func:`~.training.fit_calibration`).
    - otherwise (checkpoints from before the threshold) ``calibration`` (a, b): an
      instruction whose probabilities add up to ``s`` has ``round((s - b) / a)``
      boundaries, at its first peaks. Fitted on one- and two-step instructions, it
      extrapolates badly: it over-cut 6-7 step instructions by one in half of them.
"""

    WINDOW = 3
    MAX_STEPS = 12
    calibration: Tensor
    threshold: Tensor

    def __init__(self, vocab_size: int, dim: int = 48, gap: int = WINDOW) -> None:
        super().__init__()
        if gap < self.WINDOW:
            msg = (f"Splitter gap must be at least its WINDOW ({self.WINDOW}) tokens, got "
                   f"{gap}; set splitter_gap to {self.WINDOW} or more")
            raise ValueError(msg)
        self.gap = gap
        self.encoder = TokenEncoder(vocab_size, dim)
        self.out = nn.Linear(dim, 1)
        nn.init.constant_(self.out.bias, -4.0)  # untrained, it cuts nowhere
        self.register_buffer("calibration", torch.tensor([1.0, 0.0]))
        self.register_buffer("threshold", torch.tensor(-1.0))

    def peaks(self, probs: Tensor) -> list[tuple[int, float]]:
        """(token, window mass) of an instruction's boundary probabilities (T,), most
        probable first (see the class doc)."""
        p = probs.clone()
        out: list[tuple[int, float]] = []
        while len(out) < self.MAX_STEPS - 1 and float(p.max()) > 0:
            t = int(p.argmax())
            lo, hi = max(0, t - self.WINDOW), t + self.WINDOW + 1
            out.append((t, float(p[lo:hi].sum())))
            p[max(0, t - self.gap) : t + self.gap + 1] = 0.0
        return out

    def cuts(self, tokens: list[list[int]]) -> list[list[int]]:
        """Token positions where steps 2.. start, per instruction (see the class doc)."""
        probs = torch.sigmoid(self(pad_tokens(tokens)))
        threshold = float(self.threshold)
        out = []
        for row, tok in zip(probs, tokens, strict=True):
            p = row[: len(tok)]
            peaks = self.peaks(p)
            if threshold >= 0:
                chosen = [t for t, mass in peaks if mass >= threshold]
            else:
                chosen = [t for t, _ in peaks[: self.boundaries(float(p.sum()))]]
            out.append(sorted(chosen))
        return out

    def boundaries(self, total: float) -> int:
        """How many boundaries an instruction has whose probabilities add up to ``total``."""
        a, b = (float(v) for v in self.calibration)
        return max(round((total - b) / a), 0)

    def forward(self, tokens: Tensor) -> Tensor:
        """Boundary logits (B, T) of PAD-padded tokens (B, T); position 0 and padding are
        -inf (no step starts there)."""
        logits: Tensor = self.out(self.encoder(tokens)).squeeze(-1)
        never = tokens == PAD
        never[:, 0] = True
        return logits.masked_fill(never, float("-inf"))


class StepModel(nn.Module, metaclass=ABCMeta):
    """A model of one step: reads a piece of instruction and the world it acts on.

    ``code`` turns pieces (P, T) into whatever the model keeps per piece (P, T, C);
    ``step`` scores subject, base and action for rows that each pair a piece's code and
    tokens with an episode's object features (R, N, F), centres (R, N, 3), the previous
    step's subject (R, N; all zero in a first step) and the object mask (R, N).
    """

    perception: Perception

    def warmup_parameters(self) -> list[nn.Parameter]:
        """What the first stage trains (default: everything)."""
        return list(self.parameters())

    def features(self, crops: Tensor, mask: Tensor, sizes: Tensor) -> Tensor:
        """Object features (B, N, F) for :meth:`step` (default: the perception's)."""
        out: Tensor = self.perception(crops, mask, sizes)
        return out

    @abstractmethod
    def code(self, pieces: Tensor) -> Tensor:
        """Per-piece codes (P, T, C) of PAD-padded pieces (P, T)."""

    @abstractmethod
    def step(self, code: Tensor, tokens: Tensor, feats: Tensor, centres: Tensor,
             previous: Tensor, mask: Tensor) -> StepOutput:
        """Subject, base and action log-probabilities of each row."""


class ProgramModel(nn.Module):
    """A step model, the splitter and the action rule's fitted scalars (a buffer, so that
    the checkpoint's weights carry them): what a program model's checkpoint holds."""

    rule_values: Tensor

    def __init__(self, step: StepModel, splitter: Splitter) -> None:
        super().__init__()
        self.step = step
        self.splitter = splitter
        self.register_buffer("rule_values", torch.tensor(ActionRule().values()))

    def load_state_dict(self, state_dict: Mapping[str, Any], strict: bool = True,
                        assign: bool = False) -> Any:
        """As nn.Module's, for checkpoints of earlier designs too: the first action rule's
        three values load as they are (:meth:`ActionRule.from_values` reads them), and a
        checkpoint from before the splitter's calibration loads with (1, 0), the rounded
        sum it was trained and selected with, and one from before the splitter's threshold
        with none (it counts boundaries by its calibration)."""
        if "rule_values" in state_dict:
            self.rule_values = torch.zeros_like(state_dict["rule_values"])
        if "splitter.calibration" not in state_dict:
            state_dict = {**state_dict, "splitter.calibration": torch.tensor([1.0, 0.0])}
        if "splitter.threshold" not in state_dict:
            state_dict = {**state_dict, "splitter.threshold": torch.tensor(-1.0)}
        return super().load_state_dict(state_dict, strict, assign)

    @property
    def rule(self) -> ActionRule:
        """The action rule this model was trained with."""
        return ActionRule.from_values(self.rule_values.tolist())

    @rule.setter
    def rule(self, rule: ActionRule) -> None:
        self.rule_values = torch.tensor(rule.values())
