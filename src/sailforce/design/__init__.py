"""Design a SAIL arm before building it (issue 17): what each pose of the workspace will give.

- :mod:`.maps`: resolution, overload and compensation need at each pose, from
  the frame's sensing map; the natural modes come from :mod:`sailforce.fem.modes`;
- :mod:`.study`: the x-y grid of reachable poses, every map on it, and the summary.
"""
