"""A two-axis stage's positioning errors: the seed papers' error maps and compensation models, the
travel seen by a camera, and ISO 230-2's accuracy and repeatability.
"""
