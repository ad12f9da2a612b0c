"""UR5 riveting (EuRoC Challenge 1, Stage I, Task 2): scene, planners, the 300 s cycle, scoring."""
