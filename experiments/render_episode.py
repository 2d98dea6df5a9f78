"""One episode of a controller on a held-out bench of the realistic bench, rendered to an animated GIF (the env's
frames: reference path, contact points' paths, block, load tip, with their legend). ``triplanar demo`` shows the RL
side with it::

    python -m experiments.render_episode pi_feedback out/demo/pi_feedback.gif
"""

from __future__ import annotations

import sys
from pathlib import Path

import numpy as np

from triplanar.atomic import write_atomic

FRAME_EVERY = 4        # one frame in 4 control periods: 50 frames/s of episode time, played at 50 fps (real time)


def render_episode(controller: str, path: str | Path, bench: int = 0) -> dict:
    """``controller`` (a scripted or model-based one of ``triplanar evaluate``) on held-out bench ``bench``,
    written to ``path`` as a GIF; returns the episode's outcome (``reason``, ``mimicry_error_mm``, ``steps``)."""
    from PIL import Image

    from envs.triplanar_shear_v1 import TriPlanarShearV1Env

    from .episodes import benches_of, controller_of
    from .evaluate import scripted_batch
    batch = scripted_batch(controller, None, "heldout", bench + 1, 0)
    policy, env_kwargs, _ = controller_of(batch)
    chosen = benches_of(batch)[bench]
    env = TriPlanarShearV1Env(render_mode="rgb_array", **env_kwargs)
    obs, _ = env.reset(seed=bench, options={"bench": chosen})
    policy.reset(chosen.load_N, env.config)
    frames, steps, done = [env.render()], 0, False
    while not done:
        obs, _, terminated, truncated, info = env.step(np.asarray(policy.act(obs), dtype=np.float32))
        steps, done = steps + 1, terminated or truncated
        if steps % FRAME_EVERY == 0 or done:
            frames.append(env.render())
    images = [Image.fromarray(f) for f in frames]
    write_atomic(Path(path), lambda tmp: images[0].save(tmp, format="GIF", save_all=True, append_images=images[1:],
                                                        duration=int(1000 * FRAME_EVERY * env.dt), loop=0))
    return {"reason": info["reason"], "mimicry_error_mm": info["mimicry_error_mm"], "steps": steps}


def main(argv: list[str] | None = None) -> int:
    args = sys.argv[1:] if argv is None else argv
    if len(args) != 2:
        print("usage: python -m experiments.render_episode CONTROLLER OUT.gif", file=sys.stderr)
        return 2
    outcome = render_episode(args[0], args[1])
    print(f"{args[0]} on held-out bench 0: {outcome['reason']}, {outcome['mimicry_error_mm']:.2f} mm, "
          f"{outcome['steps']} steps -> {args[1]}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
