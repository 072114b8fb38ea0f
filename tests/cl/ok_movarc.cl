$$ Autodesk Fusion MOVARC: centre, axis, radius, ANGLE and the sweep in degrees, then the end GOTO.
UNITS/MM
FEDRAT/500., MMPM
GOTO/10., 0., 0.
MOVARC/0., 0., 0., 0., 0., 1., 10., ANGLE, 90.
GOTO/0., 10., 0.
MOVARC/0., 0., 0., 0., 0., 1., 10., ANGLE, 270.
GOTO/10., 0., 0.
MOVARC/0., 0., 0., 0., 0., -1., 10., ANGLE, 90.
GOTO/0., -10., 0.
