"""Calibration of a 6-6 Stewart platform with a laser tracker's lengths (the laser-tracker seed).

Lengths in mm, a pose is (R (3, 3), t (3,)) mapping platform-frame points into the base frame.
Leg i joins the base hinge B_i to the platform hinge r_i (platform frame); its length is
l_i + reading: |R r_i + t - B_i| = l_i + L_reading (the seed's one-step equation).

- :func:`.tracker.trilaterate`: a point from its distances to three known points (Eq. 1), with the
  covariance propagated through the distance Jacobian (Eq. 4-5).
- :func:`.tracker.multilaterate`: a point from its distances to three or more stations (least
squares).
- :func:`.tracker.locate_stations`: the tracker's stations from their lengths to three nests.
- :func:`.tracker.poses_from_lengths`: platform poses from the lengths to three reflectors.
- :func:`.legs.fit_sphere`: the centre and radius of the sphere through four or more non-coplanar
  points (Eq. 2: the two-step method's hinge point).
- :func:`.legs.two_step_leg`: the two-step method's leg from spheres at three orientations.
- :func:`.legs.calibrate_leg`, :func:`.legs.calibrate_legs`: the one-step method's seven unknowns
  of one leg (of six), with std.
- :func:`.kinematics.forward_kinematics`: the pose from six leg lengths (Newton).
- :func:`.kinematics.leg_conditions`: the legs' lengths and their Jacobian's condition at poses.
- :func:`.adjustment.adjust_jointly`: maximum likelihood over stations, poses and legs together
  (:class:`.adjustment.JointProblem`, solved by the one identification solver).
- :func:`.registration.register_frame`, :func:`.registration.register_with_legs`: the tracker's
  frame, and the legs with it, from poses the tracker measured (discovery's registration).
"""
