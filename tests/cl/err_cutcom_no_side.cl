$$ CUTCOM with a plane and no side.
CUTCOM/XYPLAN
