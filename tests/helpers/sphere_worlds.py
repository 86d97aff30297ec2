"""A GDML world for tests/test_sphere_pieces.py, written as text (pyg4ometry's import alone
takes seconds):

* ``orbhole``: a copper orb (r 3 mm) less a square hole (3 mm, along z), and ``orbpost``, a
  copper post (2.8 mm square, 10 mm long), a sister standing through the hole;
* ``dome``: a half sphere (r 10 mm) on a plate (30 x 30 x 4 mm) with a post (r 5 mm) through
  both, a union of unions;
* ``peg``: a box (20 mm) with a rod (r 5 mm, 20 mm) whose lower 15 mm are in the box;
* ``groove``: a rod (r 5 mm, 40 mm) through a box (20 mm), less a half ring (r 5 to 8 mm,
  z 8 to 16 mm, phi 0 to 180 degrees) around the rod, a groove in the box's +z face and beside
  the rod above it: ((rod | box) - half ring).
"""

from __future__ import annotations

from pathlib import Path

from helpers.boolean_worlds import copper_world_text

#: where each volume stands (mm)
AT = {
    "orbhole": (0.0, 0.0, 0.0),
    "orbpost": (0.0, 0.0, 0.0),
    "dome": (40.0, 0.0, 0.0),
    "peg": (-40.0, 0.0, 0.0),
    "groove": (0.0, 40.0, 0.0),
}
ORB_R, HOLE, POST = 3.0, 1.5, 1.4  # the orb's radius, the hole's and the post's half widths
DOME_R, DOME_POST = 10.0, 5.0  # the half sphere's radius, the post's
PEG_Z = 5.0  # the rod's centre above the box's


def write_sphere_world(path: Path) -> Path:
    full = 'startphi="0" deltaphi="360" aunit="deg" lunit="mm"'
    solids = f"""
<box name="world_s" x="200" y="200" z="200" lunit="mm"/>
<orb name="orbhole_a" r="{ORB_R}" lunit="mm"/>
<box name="orbhole_b" x="{2 * HOLE}" y="{2 * HOLE}" z="10" lunit="mm"/>
<subtraction name="orbhole_s"><first ref="orbhole_a"/><second ref="orbhole_b"/></subtraction>
<box name="orbpost_s" x="{2 * POST}" y="{2 * POST}" z="10" lunit="mm"/>
<sphere name="dome_a" rmin="0" rmax="{DOME_R}" {full} starttheta="0" deltatheta="90"/>
<box name="dome_b" x="30" y="30" z="4" lunit="mm"/>
<union name="dome_u"><first ref="dome_a"/><second ref="dome_b"/>
  <position name="dome_p" x="0" y="0" z="-2" unit="mm"/></union>
<tube name="dome_c" rmin="0" rmax="{DOME_POST}" z="18" {full}/>
<union name="dome_s"><first ref="dome_u"/><second ref="dome_c"/>
  <position name="dome_q" x="0" y="0" z="5" unit="mm"/></union>
<box name="peg_a" x="20" y="20" z="20" lunit="mm"/>
<tube name="peg_b" rmin="0" rmax="5" z="20" {full}/>
<union name="peg_s"><first ref="peg_a"/><second ref="peg_b"/>
  <position name="peg_p" x="0" y="0" z="{PEG_Z}" unit="mm"/></union>
<tube name="groove_a" rmin="0" rmax="5" z="40" {full}/>
<box name="groove_b" x="20" y="20" z="20" lunit="mm"/>
<union name="groove_u"><first ref="groove_a"/><second ref="groove_b"/></union>
<tube name="groove_c" rmin="5" rmax="8" z="8" startphi="0" deltaphi="180" aunit="deg" lunit="mm"/>
<subtraction name="groove_s"><first ref="groove_u"/><second ref="groove_c"/>
  <position name="groove_p" x="0" y="0" z="12" unit="mm"/></subtraction>"""
    path.write_text(copper_world_text(solids, AT))
    return path
