"""3-DOF articulated arm of the Newton-Raphson project (seed 001): model and closed form."""
