// Balls on a found pool table (seed 4.3.2, 4.3.3, 4.3.5, figure 4.10): non-cloth blobs
// inside the table with size limits from the pose, touching balls split, each ball's
// position fitted as a sphere of the ball radius resting on the cloth (the silhouette of
// a sphere is an ellipse whose centre is not the projection of the ball's centre, and the
// shaded underside and the shadow must not pull the estimate: the whole silhouette is
// fitted, then its outline refined on the colour edge), ball numbers by per-pixel colour
// votes (seed eq. 4.3 for the cue, 1 and 9, with white and yellow unmixed per pixel; the
// red 3 and maroon 7 told by the ball's saturation) with each number used once, and the
// empty-table background.
#pragma once

#include <array>
#include <vector>

#include <opencv2/core.hpp>

#include "absl/status/statusor.h"
#include "common/planar_pose.h"
#include "common/pool_profile.h"

namespace texfree {

struct PoolBallOptions {
  // A pixel counts as ball when its colour angle to the cloth exceeds this (seed: 10).
  double ball_angle_deg = 10;
  // Width of the soft transition around ball_angle_deg, degrees.
  double ball_angle_soft_deg = 4;
  // A pixel also counts as ball when its chromaticity (opponent chroma over intensity;
  // a saturated primary is about 1.5-3) is this far from the cloth's: a ball of nearly the
  // cloth's hue but of another saturation, like the green 6 on green cloth.
  double ball_chroma_distance = 0.35;
  // Pixels darker than this fraction of the cloth brightness are ball (the 8 ball).
  double dark_fraction = 0.3;
  // In an sRGB picture (pixel_encoding), pixels brighter than this multiple of the cloth's
  // brightness (B + G + R) are ball as well. A ball of the cloth's own hue but lighter, as
  // the red 3 on burgundy cloth, has the cloth's chromaticity over its lit body; only its
  // highlight and its shaded rim were ball, a crescent that the fits slid along or lost
  // (seed 7's set on red cloth, 60 frames: the 3 lost in five frames it stood alone in).
  // Over the cloth the light varies less than that, and the white and coloured balls are
  // ball by colour already: on green cloth the twenty benchmark sets are unchanged by it.
  // Red cloth, sRGB, seeds 7 and 11 (60 frames): separated balls named 304 + 282 -> 310 +
  // 284 of 317 + 290, located 451 + 466 -> 459 + 470, false balls 22 + 16 -> 16 + 14. At
  // 1.3 the brighter patches of the cloth under the lamps were balls (351 false balls).
  // Linear pictures are left out: at 1.6 there, red seed 11 named 5 balls more but placed
  // 5 more over 10 mm. 0 turns this off.
  double bright_fraction_srgb = 1.6;
  // A ball of nearly the cloth's hue and darker than it (a dark teal-green 6 on green
  // cloth): its body is 0.45-0.85 of the cloth's brightness and within the noise of the
  // cloth's chromaticity, so only its highlight was ball and the ball was lost. Around a
  // highlight (a small blob 1.3 times as bright as the cloth) whose ball is not seen
  // already (under a third of the disc of its apparent radius ball by colour, under half
  // ball at all), the pixels under this share of the cloth's brightness (as lit there,
  // CushionShade) within 1.2 apparent radii are ball. texfree-bench-pool --ball-set second
  // (seeds 7-17 and 43-59, sRGB): located 3,762 -> 3,791 of 3,840, separated named 2,463
  // -> 2,487 of 2,498, over 10 mm 85 -> 73. 0 turns this off.
  double cloth_hue_ball_dark_share = 0.8;
  // Next to the cushions, where the cloth is darker than elsewhere (and on a cushion's face
  // that is itself as dark as a dark ball), a pixel is dark (ball) only when it is also
  // darker than this share of the cloth as lit there: a lamp not over the table's middle
  // leaves a cushion's face, and a band of the cloth along it, in the cushion's shadow,
  // and with darkness measured against the cloth's colour alone they read as a row of
  // black balls. The cloth's level next to each cushion is the median brightness of the
  // cloth-coloured pixels of each cell of bands along it (2 ball radii deep, 8 long) and
  // of its face. Lamps moved 500 mm sideways (texfree-bench-pool --lamp-shift 0,500,0,
  // seeds 7 and 19): 175 + 101 false balls without this, 10 + 10 with it; 1,000 mm
  // sideways and 300 up: 168 + 99 -> 13 + 22; lamps 300 mm lower: 6 + 4 -> 6 + 3. On
  // the twenty benchmark sets, balls over 10 mm 54 + 79 -> 50 + 76, false balls 20 + 22
  // -> 19 + 19. At 1 (the level itself) half a face's pixels stay dark: 33 + 27 false
  // balls in the first shifted sets, 19 + 14 at 0.8. 0 turns this off.
  double cushion_shade_dark_share = 0.4;
  // A blob is kept when its area is at least this fraction of one ball's silhouette.
  double min_area_fraction = 0.3;
  // A cue stick over the cloth (a player aiming) and its shadow are long strips of ball-ness
  // thinner than a ball: a shaft is 13 mm across, a butt 26-30 mm, a ball 2 r. Strips
  // that an opening with a disc of stick_opening_radius ball radii removes (thinner than
  // about twice that), that run at least min_stick_length ball radii and at least
  // min_stick_elongation times their mean width, are the stick, and so are the thin pixels
  // along their line (the stick is straight): they give no seeds, and the fits leave them
  // out. At 0 nothing is a stick. A ball under the stick keeps its own disc (the opening
  // keeps it whole); the necks between touching balls are removed too, but are short.
  // With a stick aimed through the cue ball in every frame (texfree-bench-pool --cue-stick,
  // 30 frames of each of the ten seeds): 587 false balls without this, 98 with it. On the
  // ten sets without a stick only seed 11's frame 25 changed (a low camera, 12 mm a pixel
  // along the line of sight): its far 6 from 9.2 to 13.7 mm, its 8 from 13.4 to 11.5 mm.
  double stick_opening_radius = 0.7;
  double min_stick_length = 3;
  double min_stick_elongation = 4;
  // ...along their line over the cloth only up to this many ball radii past each strip's
  // ends (enough to bridge a ball the stick passes over, or the cue ball at its tip), and
  // without limit beyond the cloth (over the cushions and the rail no ball lies). Unlimited
  // over the cloth, the line ran on through the cue ball to the object ball beyond it, in
  // the line of aim, and took the thin pixels of its outline. With the limit at 6, the ten
  // stick sets locate 3 more balls and name 3 more separated ones (2,352 and 1,527), and
  // the false balls stay 98.
  double stick_bridge_length = 6;
  // A fitted ball is kept when the mean ball-ness over its silhouette (the pixels other
  // balls leave to it) is at least this. A small, soft green 6 on green cloth is a dark
  // ring around a lit cap and a highlight of nearly the cloth's colour: fitted within
  // 6 mm, it scored 0.40-0.48, and at 0.5 seven separated 6s of six benchmark sets were
  // lost; at 0.4 they are found. A ball that the pair rule moved out of its neighbour
  // (placed by the rule, not by its own pixels) must still be half ball: at 0.4 one of
  // them, behind a touching pair, stood as a false ball in seed 37's frame 48.
  double min_fit_ballness = 0.4;
  // A fit not moved out of a neighbour and under min_fit_ballness is kept when it is at
  // least this much ball both as fitted and by colour alone over its whole silhouette (the
  // zone under it counted): a green 6 on green cloth whose lit cap reads as cloth is a
  // third to two fifths ball, and a shadow or a shaded cushion, ball by darkness alone, is
  // not ball by colour. Over the twenty benchmark sets rendered sRGB, the fits thrown away
  // unmoved at 0.3-0.4 were all real 6s (4 of 25 fits thrown away; the others, moved out
  // of a neighbour, shadows and halves of balls); kept, 4 balls more located, 2 more
  // named, no false ball more (at 0.33 overall alone, seed 7's set with the lamps off the
  // table's middle had 9 false balls against 4). 0 turns this off.
  double min_fit_ballness_by_colour = 0.33;
  // Seed eq. 4.3 thresholds on the white share of the cue/1/9 votes (seed: 0.7 and 0.3).
  // The 1's white is its number circle and the highlight, rarely over a fifth of its
  // visible pixels, while a 9 lying with its stripe towards the camera shows little
  // more: 0.2 separates them better than the seed's 0.3 on rendered and real balls.
  double cue_white_share = 0.7;
  double one_white_share = 0.2;
  // Where a ball's white lies tells the 1 from the 9 when their white shares agree (0.25-0.4
  // both: a 1 with its number circle towards the camera, a 9 with its stripe): the white
  // share that decides between them is white_share + this weight times white_outward.
  // Over the ten green benchmark sets, a single threshold on the white share alone misread
  // 52 of 1,034 1s and 9s, and on the share with 0.5 of white_outward 14.
  double white_outward_weight = 0.5;
  // ...of white_outward less what a 1 shows: its highlight and number circle lie a little
  // outside the middle of its yellow (median 0.04 on the benchmark's 1s).
  double white_outward_of_one = 0.08;
  // The orange 5 and the yellow 1 are a chroma step apart: blur, JPEG's halved colour
  // resolution and the green cloth mixed in turn orange pixels yellow, while no mixture
  // turns yellow orange. So when orange is over this share of a ball's yellow + orange
  // votes (1s and 9s of the benchmark: under 0.05; 5s: 0.42 and up), its yellow votes
  // are taken as a faded 5 (fully from twice this share).
  double five_orange_share = 0.15;
  // A ball stays unnamed when no number left to it scores over this (PoolNumberScores: its
  // share of the votes that speak for the number). At 0.15, a washed-out 5 (4 orange votes
  // of 47, its yellow read as the 1/9 group's, the 1 and the 9 taken by clearer balls) was
  // left unnamed on the benchmark's seed 17, and a 9-ft set ball likewise; at 0.08 both are
  // named, no other ball of the ten green sets is named otherwise, and one false ball (a
  // dark patch on seed 29, no 8 found in that frame) is named 8 instead of nothing.
  double unnamed_score = 0.08;
  // In an sRGB picture (pixel_encoding kSrgb) the cue ball's and the 6's scores fall from
  // full at half this share of black votes to none at it: their shaded sides are lifted to
  // grey and dark green. Over the twenty sets rendered sRGB no cue ball had more than 0.053
  // of its votes black and no 6 more than 0.086, while an 8 whose white number disc faces
  // the camera has 0.1-0.5: it was read as the cue ball 5 times, and on green cloth, its
  // few dark pixels tinted by the cloth, as the 6 3 times. In a linear picture a cue
  // ball's shaded side reads black (up to 0.27), and this is not used. 0 turns it off.
  double max_black_share_srgb = 0.12;
  // A ball that the overlap rule placed (moved out of a neighbour it overlapped, to touch
  // it) stands there by the rule, not by its own pixels: a dark fit moved out of a
  // coloured ball is often that ball's shadow. Its number scores are weighed by this, so
  // that in a contest for a number a ball fitted on its own pixels wins. On the
  // benchmark's seed 19 (frame 34) a shadow under the 9 took the 8 (0.67 of its votes
  // against the real 8's 0.54, whose number circle and highlight vote white) and left the
  // separated 8 unnamed; at 0.5 no other ball of the ten green, the 9-ft, the blue or the
  // burgundy sets is named otherwise.
  double moved_number_weight = 0.5;
  // Fits still closer than two radii at the end are moved apart along the line between
  // them, each by half the overlap (SeparateOverlappingBalls): two balls cannot
  // interpenetrate, and the fits of a touching pair seen one behind the other slide into
  // each other (the nearer one's far side and the farther one's near side are against
  // ball, not cloth). On the ten green sets: 61 -> 55 balls over 10 mm, mean 2.57 -> 2.52
  // mm; ten held-out sets: 96 -> 90, 2.70 -> 2.65 mm; no ball named otherwise. A pair
  // seen one behind the other (line_of_sight_pair_deg) is separated by moving the nearer
  // ball alone: the farther one's far rim against the cloth holds its fit, the nearer
  // one's far side is against the farther ball (mean 2.52 -> 2.45 mm on the ten green
  // sets, 2.65 -> 2.59 mm on the held-out sets; balls over 10 mm 55 -> 55 and 90 -> 89).
  bool separate_overlapping_fits = true;
  // Two fits of different colours closer than the overlap rule allows: the worse fit is
  // moved out to touch the better one, except for a touching pair seen one behind the
  // other (the line between them within this many degrees of the line of sight, and more
  // than a radius apart, so two fits of one ball are not taken for a pair). There the
  // nearer ball is held only at its sides (its far side is against the other ball, its
  // lower part in the dark zone under it) and its fit slides into the far ball, whose far
  // outline against the cloth holds it; both fits cover mostly ball pixels, so the worse
  // of the two is a toss-up, and when the far ball was moved both stood 2-3 px away from
  // the camera. With the nearer one moved out (45), balls over 10 mm on the ten green
  // sets went 74 -> 58 and none got worse. The final separation of overlapping fits
  // (separate_overlapping_fits) takes the same angle. 0 turns this off.
  double line_of_sight_pair_deg = 45;
  // Two seeds closer than this many ball radii after the first fits are one ball (its dark
  // underside and shadow lengthen its blob into two seeds): only the better fit is kept.
  // Touching balls fitted each within a few millimetres stay 2 radii apart; a touching
  // pair seen one behind the other, its nearer ball fitted 1.4-1.5 radii from the far one,
  // was merged at 1.5 (seed 23's frame 23: the 8 and the 1 became one ball that took the
  // 9's number). At 1.4, on the ten green sets 6 more balls are located and that 9 is
  // named; one pair that was one ball (seed 29's frame 33, the 7 in front of the 4) is
  // two, 23 mm off.
  double seed_merge_distance = 1.4;
  // The silhouette fit leaves out the dark zone under a ball (its unlit underside and its
  // shadow are ball by darkness, not by shape). In its second pass, where every other fit
  // is claimed, a pixel of that zone outside the silhouette that is this much ball by
  // colour alone or more counts against the fit as a ball pixel it leaves out: it is this
  // ball's own, and the fit has slid off it. Left out, the nearer of two touching balls
  // seen one behind the other slid onto the farther one, its own pixels then all in that
  // zone (seed 11's frame 15 rendered sRGB: the red 3 in front of the blue 2, both 20 mm
  // off, 2.5 px up the picture; now 3.8 and 4.8 mm). In the first pass the farther balls
  // are not fitted yet and the nearer one's pixels would pull them down onto it. Over the
  // twenty benchmark sets, sRGB: balls over 10 mm 63 + 69 -> 56 + 67, located 4,771 +
  // 4,761 -> 4,787 + 4,776, false balls 12 + 8 -> 7 + 4; linear: 52 + 68 -> 49 + 69,
  // located 4,763 + 4,758 -> 4,773 + 4,766, false balls 19 + 17 -> 15 + 15. 0 turns this
  // off.
  double colour_below_ballness = 0.5;
  // The same count in the first pass for the nearest ball of a blob that holds other
  // seeds: fitted first, with nothing of the blob claimed, it is the one that slides onto
  // the ball behind it, and a farther ball of the blob is not yet fitted to be pulled down
  // (seed 73's frame 33 rendered sRGB: the 5 in front of the 7, 11.2 mm up the picture
  // onto it and the 7 lost; now 0.3 and 0.5 mm). Over the twenty benchmark sets, sRGB:
  // balls over 10 mm 56 + 67 -> 53 + 65, located 4,787 + 4,776 -> 4,788 + 4,780; linear:
  // 49 + 69 -> 47 + 66, located 4,773 + 4,766 -> 4,779 + 4,772. 0 turns this off.
  double colour_below_front_ballness = 0.5;
  // Two fits closer than a ball's radius are two fits of one ball (ResolveOverlaps keeps
  // one). Which is kept is decided by the ball-ness, which counts the ball's dark
  // underside and shadow as ball, so a fit slid into its shadow can win; when either fit
  // is at least this much ball by colour alone (over its silhouette and the zone under
  // it, where a shadow is cloth), the one more ball by colour is kept instead (seed 7's
  // frame 8 on red cloth, rendered sRGB: the maroon 7 kept on its shadow 23.4 mm towards
  // the camera; now under 6 mm). With colour_below_front_ballness, over the twenty sets:
  // balls over 10 mm on the held-out sets 65 -> 64 (sRGB) and 66 -> 65 (linear), the
  // others alike. 0 turns this off.
  double same_ball_colour_ballness = 0.33;
  // The light's colour. Bar lamps are warm (2700-3000 K) and a camera's white balance
  // corrects only part of it: the white cue ball then reads as yellow (the 1 or the 9), the
  // maroon 7 as the red 3, and the 6 nears the cloth's colour. The white of the balls in
  // view (the cue, the 9's caps: bright pixels of low saturation on balls that are mostly
  // such pixels) is compared with the profile's cue colour; when a channel's gain to bring
  // it back is off 1 by more than this share, the balls are found again on the picture
  // with those gains applied (and the cloth colour with it). A profile whose colours were
  // learned under the table's own light (CalibrateColors) sees no cast. 0 turns this off.
  double white_balance_min_cast = 0.06;
  // A ball is taken as darker than the cloth (its outline beside its shadow left out of
  // the edge pass, then fitted on its far rim, as below) when the median brightness of its
  // body (its pixels without the white of its number disc and highlight) is under 0.9 of
  // the cloth's, or when the near half of its silhouette (the pixels more than 0.18
  // apparent radii from its centre towards the camera), in light, is under this share of
  // the cloth's light. A ball whose lit top is as bright as the cloth can have a lower
  // half dark against its shadow: taken for a bright ball, the edge pass slid it into
  // that shadow (benchmark seed 23's frame 42 rendered sRGB, a 6 11.9 mm towards the
  // camera, 3.1 mm with this; seed 7's frame 53, a purple 4, 12.4 -> 3.1 mm). Every
  // ball's lower half is shaded by the lamps above, so the share must be well under 1:
  // over the twenty benchmark sets rendered sRGB, with the ball's median for its body
  // (session 31's round 47), balls over 10 mm 126 + 151 -> 94 + 124 at 0.5, means 2.59 +
  // 2.73 -> 2.57 + 2.71 mm (at 0.9 of the brightness as encoded: 101 + 134, but 2.74 +
  // 2.91 mm, the lower half of the 2, the 4 and the 7 under it); linear 50 + 75 -> 50 +
  // 74. With the body (round 49), 81 + 98 -> 72 + 98 over 10 mm. 0 turns this off.
  double near_half_dark_share = 0.5;
  // Whether a ball darker than the cloth, of the cloth's hue or of none (a green 6 on green
  // cloth, the 8), in an sRGB picture has the edge pass (the mean fall of its colour
  // distance over its outline) between its silhouette fit and its rim fit. Encoded, its
  // shadow is 0.6-0.75 of the cloth's brightness, not dark enough to be ball-ness, so the
  // silhouette fit is not drawn into it; the edge pass was, by a white number disc whose
  // edge is a stronger fall than the ball's own against the cloth (held-out seed 61's
  // frame 12: a 6 4.0 mm off on its rim from its silhouette fit, 21.7 mm from the edge
  // pass's). A ball of another hue (the purple 4, the blue 2) has a clear outline and
  // keeps it. Over the twenty benchmark sets rendered sRGB, balls over 10 mm 87 + 117 ->
  // 72 + 98 without it (73 + 106 without it for every ball darker than the cloth, four
  // 4s then over 10 mm). In a linear picture the shadow, at 0.3-0.5 of the cloth, is
  // partly dark ball-ness and the edge pass takes the fit out of it (without it there,
  // 51 + 73 -> 56 + 88): a linear picture always has it.
  bool darker_edge_pass_srgb = false;
  // Such a ball, fitted from its silhouette straight to its far rim, is placed this share
  // of the way back from its rim fit to its silhouette fit. The two measure it apart: the
  // silhouette fit the ball-ness over its whole area, the rim fit the far third of its
  // outline. Over the 1,671 such balls of the twenty sRGB benchmark sets (6s and 8s),
  // their errors are uncorrelated (correlation 0.02) with RMS 7.96 mm (silhouette) and
  // 6.02 mm (rim), which weights the silhouette fit 0.36 by inverse variance. At 0.3 the
  // balls' mean error went 4.57 -> 3.50 mm before the later stages (10 mm: 103 -> 72); over
  // the twenty sets, 0.25-0.35 measured alike and 0.45 worse. 0: the rim fit alone.
  double straight_rim_silhouette_share = 0.3;
  // A ball darker than the cloth (the 8, a shaded 6) has its shadow, as dark as itself,
  // joined to the near side of its outline; the far side, where the cloth seen beyond the
  // ball lies behind it, is its one clean edge. When set, its rim fit takes rim points on
  // that side only.
  bool rim_far_side_only = true;
  // The rim fit scans each outline normal 0.6 radius (at least 3 px) either side of the
  // outline. Where a scan on the far side starts inside the ball, it goes on outwards for
  // up to this many apparent radii more to find the cloth: the edge pass can leave a dark
  // ball 4-6 px down in its shadow, out of reach of its far rim. 0 turns this off.
  double rim_outward_reach = 0.6;
  // A ball darker than the cloth whose median saturation (chroma over intensity) is under
  // this share of the cloth's, a grey or black one, is fitted on its rim in the full
  // colour distance from the cloth rather than mostly in chromaticity: its far rim is its
  // lit top, nearly as bright as the cloth and without chromaticity of its own. A
  // saturated ball (the green 6 on green cloth, about 1.5 of the cloth's) keeps the
  // chromaticity, which tells it from the cloth of its own hue. 0 turns this off.
  double rim_full_colour_saturation = 0.5;
  // A ball not darker than the cloth is refined, after the edge pass, on its edge points:
  // along each outline normal, up to this many apparent radii (at least 2 px) either
  // side, the outermost peak of the fall of the colour distance whose outer side is at
  // the cloth's level. The edge pass maximises the mean fall over the outline, so where a
  // ball's contrast varies along its outline (a lit lower half, a shaded upper half) the
  // outline points at its sides pull it to where they sample the strongest contrast, not
  // to where the edge is. 0 turns this off.
  double edge_point_reach = 0.5;
  // The edge pass reads a ball's colour distance from the cloth capped at this quantile
  // of the distance over its interior (the pixels 1 px or more inside its silhouette fit's
  // outline), so that only the step from the cloth up to the ball's own level is an edge
  // to it. Uncapped, a contrast inside the ball that is stronger than the ball's against
  // the cloth drew the outline to itself: the lower edge of a green 6's white number disc
  // took the 6 2-3 px towards the camera (held-out seed 47's frame 54: 4.5 mm off on its
  // silhouette fit, 21.5 mm after the edge pass, 4.5 mm now). Only for a ball of 4 px
  // apparent radius or more: a smaller one has no interior out of the blur's reach of its
  // outline (the 9-ft table's far balls). Over the twenty benchmark sets rendered sRGB,
  // balls over 10 mm 72 + 98 -> 64 + 73; linear 51 + 73 -> 52 + 68. 1 turns this off.
  double edge_interior_level = 0.65;
  // The edge pass's position counts in that fit as this many edge points lying on its
  // outline: where a neighbour or the shadow zone leaves edge points on one side only,
  // the fit is poorly held across them and would slide along that direction.
  double edge_point_prior = 4;
  // The edge pass (and, for a ball not darker than the cloth, the edge-point fit) is not
  // kept when it leaves the mean ball-ness under the silhouette more than this below the
  // silhouette fit's (0.15): the ball-ness is the ball's colour or darkness, and a fit
  // that moves a good part of the silhouette onto the cloth was drawn by another edge
  // (the shaded face of the far cushion behind a green 6 took one 2 px up, 17 mm). For a
  // ball darker than the cloth (whose ball-ness is partly its shadow's) only where a
  // cushion's face is seen just beyond its top (round 34). 1 turns this off.
  double edge_max_ballness_drop = 0.15;
  // An edge point on the outline's far side whose outside (0.5-2 px beyond it) has a
  // pixel darker than this fraction of the local cloth's brightness (0.75) is taken on
  // the fall of the luma instead, when that lies no farther out: the colour distance is
  // mostly chromaticity, and against a dark background (the ball's shadow cast behind it,
  // the far cushion's shaded face) JPEG's halved colour resolution spreads the ball's
  // colour into pixels whose chromaticity it then dominates, so the colour's fall lies a
  // pixel or two outside the ball; the luma keeps the full resolution. Benchmark seed 13's
  // frame 3 5 and seed 11's frame 32 1, in front of the far cushion: their top edge points
  // 1.3-1.8 px outside the ball, 12.7 and 10.0 mm away from the camera. 0 turns this off.
  double edge_shade_brightness = 0.75;
  // Every edge point of a ball brighter than the cloth in luma (the cue, the 1, the 9, the
  // 5 on a green cloth) is moved to the luma's outermost fall when that lies within this
  // many pixels of it (and within 0.15 of the apparent radius, on a small far ball): the
  // colour distance weighs chromaticity, which JPEG keeps at half resolution, and a
  // blurred rim's mix takes on a bright ball's chromaticity faster than its share of the
  // ball, so the colour's fall lies outwards; with the dark lower outline left out, that
  // put the bright balls 0.3 px up the picture, away from the camera (round 28). The luma
  // keeps the full resolution, as for the table's sides. 0 turns this off.
  double edge_luma_snap_px = 1.0;
  // How the picture encodes the light (PixelEncoding). Three readings of an sRGB picture
  // are made on its colours decoded to light. The edge fit: a blurred outline is a mix of
  // ball and cloth in light, so its steepest fall, where the outline lies, is found in
  // light; read as encoded, a bright ball's outline lies outside it and a dark one's inside
  // (texfree-bench-pool --srgb, the ten green and ten held-out sets: mean 3.25 / 3.31 mm
  // read encoded, 2.56 / 2.67 mm decoded). The colour angle to the cloth (BallnessMap):
  // shading scales a colour in light but turns it when encoded. The red 3 and maroon 7's
  // cues (PoolRedShareOfThree). kSrgb: a phone's picture; kLinear: values in proportion to
  // the light (a raw-like picture, the benchmark's renderer by default).
  PixelEncoding pixel_encoding = PixelEncoding::kSrgb;
  // A ball seen behind another one along the line of sight shows only a crescent above
  // it: their blob has about two balls' area for the pose but a single distance maximum,
  // and its one seed's silhouette settles on the farther ball or between the two. Such a
  // blob is also fitted as two balls, each with the other's silhouette claimed and never
  // into it. The pair is kept when each of the two alone (its pixels at least a pixel
  // outside the other's outline) covers at least split_hidden_min_visible of a ball's
  // silhouette (two fits that overlap more cannot be told from one ball), when the second
  // ball's mean ball-ness is at least split_hidden_min_ballness (a fit on a ball's own
  // lower half and shadow is part cloth), and when the second is not a dark patch in
  // front of the first (its shadow). 0.25 / 0.85; split_hidden_min_visible 0 turns this off.
  double split_hidden_min_visible = 0.25;
  double split_hidden_min_ballness = 0.85;
  // Not for balls under this apparent radius, pixels (5): a hidden ball's crescent is then
  // a pixel or two thick, lost in the blur and JPEG's halved colour resolution, and the
  // shaded cloth beyond a small ball looks the same (the 9-ft set's 3-4 px balls).
  double split_hidden_min_radius_px = 5;
  // Nor for a blob that one ball explains: fitted as one ball (its whole silhouette, the
  // dark zone under it counted), fewer of its pixels than this share of a ball's area lie
  // more than 1.5 px outside that silhouette (the blur's and JPEG's halo around a ball).
  // A small ball's blob, halo and all, has about 1.65 times a ball's area and was tried
  // as a pair: its lit top and lower half were kept as two balls when that half was not
  // dark, which is how a phone's sRGB picture shows it (texfree-bench-pool --srgb, seeds
  // 7, 11, 13, 17, 19: 23 such splits with 0.05-0.47 of a ball outside, the 7 real pairs
  // 0.46-0.78). The twenty sets rendered sRGB: balls over 10 mm 202 + 230 -> 150 + 181,
  // false balls 75 + 61 -> 21 + 12, separated balls named 3,013 + 3,069 -> 3,048 +
  // 3,096; rendered linear: 50 + 76 -> 50 + 75. 0 turns this check off.
  double split_hidden_min_unexplained = 0.4;
  // A ball pixel darker than dark_reflection_brightness of the lit cloth whose hue is
  // within dark_reflection_hue_deg of the cloth's votes for the 8: a glossy black ball
  // mirrors the cloth on its lower half, and JPEG's colour smear tints its dark pixels
  // the same way, so on green cloth they read as the dark green 6 (4 of benchmark seed
  // 19's 8s were read as the 6). A 6's own pixels are 0.35-0.5 of the cloth's brightness
  // and its lit top brighter: its votes under 0.2 are a few percent. 0 turns this off.
  double dark_reflection_brightness = 0.2;
  double dark_reflection_hue_deg = 30;
  // In an sRGB picture (pixel_encoding kSrgb), a ball pixel of a solid colour within
  // dark_reflection_hue_deg of the cloth's whose colour (its chroma over the lit cloth's
  // brightness) is under this share of the cloth's own votes for the 8, however bright:
  // JPEG halves the colour resolution, and the 8's dark pixels beside the cloth or its
  // white disc take the cloth's colour at a fifth to a third of its strength, where the
  // green 6's own pixels carry 0.35 and more of it (99th percentile over the twenty sets
  // rendered sRGB). An 8 was read as the 6 in 12 of them. In a linear picture a 6's shaded
  // pixels carry as little colour, and its 8s were read as the 6 once: it is not used
  // there. 0 turns this off.
  double dark_reflection_chroma_srgb = 0.3;
  // A chromatic ball pixel brighter than the lit cloth votes for the solid colour nearest
  // to it in the chroma plane, taken as the segment from this share of the colour's chroma
  // up to all of it: a pixel mixing a ball's colour with white (highlight, number disc,
  // blur) lies on that segment nearer grey. By the colour's point, the orange 5's pale
  // pixels were nearer the maroon 7, which is less saturated, and a 5 of a few pixels was
  // read as the 7 or the 3 (the 9-ft table rendered sRGB: 84% of separated balls named).
  // 0.4-0.7 name the same over the twenty sets rendered sRGB. 1: the colour's point alone.
  double vote_min_colour_share = 0.5;

  absl::Status Validate() const;
};

// Per-pixel colour votes of one ball: index 0 = white (cue), 1..8 the solid colours.
// Fractional: a pixel that mixes the white and the yellow of the 9 votes for both.
using PoolVotes = std::array<double, 9>;

struct PoolDetectedBall {
  int number = -1;          // 0 = cue, 1..9; -1 = a ball whose number is unknown
  double x_mm = 0, y_mm = 0;  // centre on the table (at Z = ball radius)
  cv::Point2d ideal_pixel;    // projection of the centre, ideal (undistorted) pixels
  double radius_px = 0;       // apparent radius
  double fit_score = 0;       // mean ball-ness under the fitted silhouette, 0..1
  double confidence = 0;      // of the number, 0..1
  PoolVotes votes{};
  double white_share = 0;  // b_c / b_sum of eq. 4.3: white over white + yellow votes
  // How much farther from the centre (in apparent radii) its white votes lie than its
  // yellow ones: a 9 with its stripe towards the camera shows its white caps at the
  // outline, a 1 its number circle and highlight inside it.
  double white_outward = 0;
  // Saturation (chroma over intensity, upper quartile) of its red pixels, which tells the
  // red 3 from the maroon 7; 0 when it has none. Of an sRGB picture, in light
  // (PoolBallOptions::pixel_encoding).
  double colour_saturation = 0;
  // Brightness of its red pixels (upper quartile) over the cloth's around it: the red 3
  // reflects about half as much again as the maroon 7; 0 when it has no red pixels. Of an
  // sRGB picture, in light.
  double colour_brightness = 0;
};

// Finds and identifies the balls. `ideal_bgr` is the undistorted image, `pose` the table
// pose (table frame, Z = 0 cloth), `cloth_bgr` measured on the image. `light_gains`
// (optional, BGR): the light's white balance (options.white_balance_min_cast) found on an
// earlier picture of the same table, applied at once; on return, the gains this picture
// was read with when its balls and cloth showed a cast, else left as passed.
// `ball_size_ratio` (optional): how large the balls look against what the pose and the
// profile predict, the median over the ball blobs of each one's largest inscribed circle
// over a ball's apparent radius there (touching balls count once each: the circle fits
// one of them). About 1.1 with the right profile (the blur grows a blob a little); a
// profile of a larger table than the one in view, for its balls, puts the table farther
// away and the balls look larger in proportion. 0 when fewer than three blobs were seen.
std::vector<PoolDetectedBall> DetectPoolBalls(const cv::Mat& ideal_bgr, const cv::Matx33d& K,
                                              const PlanarPose& pose,
                                              const PoolTableProfile& profile,
                                              const cv::Vec3b& cloth_bgr,
                                              const PoolBallOptions& options = {},
                                              cv::Vec3f* light_gains = nullptr,
                                              double* ball_size_ratio = nullptr);

class IdealView;
// The same on a picture undistorted on demand (pool_table.h): makes valid the part of
// view->full() around the table that the balls are looked for in, and reads only that.
std::vector<PoolDetectedBall> DetectPoolBalls(
    IdealView* view, const cv::Matx33d& K, const PlanarPose& pose, const PoolTableProfile& profile,
    const cv::Vec3b& cloth_bgr, const PoolBallOptions& options = {},
    cv::Vec3f* light_gains = nullptr, double* ball_size_ratio = nullptr);

// Moves balls whose centres are closer than 2 * `radius` (mm, on the table) apart along the
// line between them, each by half the overlap, until they touch (within 0.01 mm; in rounds,
// as a moved ball may meet a third). A pair whose line lies within `line_of_sight_pair_deg`
// of the camera's line of sight (on the table) is separated by moving the nearer ball
// alone (0: every pair by halves). Their ideal pixels and apparent radii follow (`pose`,
// `K`).
void SeparateOverlappingBalls(const PlanarPose& pose, const cv::Matx33d& K, double radius,
                              std::vector<PoolDetectedBall>* balls,
                              double line_of_sight_pair_deg = 0);

// Seed eq. 4.3 and the nearest-colour votes: a score for each number 0..9.
// `white_outward` as PoolDetectedBall's (0: no information on where the white lies).
std::array<double, 10> PoolNumberScores(const PoolVotes& votes, const PoolBallOptions& options,
                                        double white_outward = 0);

// Share (0..1) of a red ball's votes that go to the red 3 rather than the maroon 7. Two
// cues tell them apart against the profile's calibrated colours: saturation (chroma over
// intensity) and brightness over the cloth's (the 3 reflects about half as much light
// again as the 7). Each is scaled by the gap between the two calibrated colours in it.
// In a linear picture (kLinear) brightness also depends on where the ball sits in the
// light, so it only decides a ball whose saturation lies within half the gap of the middle
// (a small ball loses some saturation to the cloth mixed in at its edge), never against a
// clear saturation. In an sRGB picture (kSrgb, the cues read in light and the profile's
// colours decoded alike) JPEG's colour smear takes more of a small 3's saturation, and the
// roles are the other way round: brightness decides, saturation tips.
// `brightness` <= 0: saturation alone.
double PoolRedShareOfThree(double saturation, double brightness, const PoolTableProfile& profile,
                           PixelEncoding encoding);
// The same for two red balls of one picture, one of which is the 3 and the other the 7:
// the share of ball a's votes that go to the 3 (ball b's is one minus it), from their
// differences in the two cues (saturation, and brightness capped as above). Both balls lose
// saturation alike to the blur and the light of one picture: the far 3 of benchmark seed
// 31's frame 32 measured 1.11 and 1.62 (saturation, brightness), its 7 1.14 and 1.10, each
// nearer the calibrated 7 in saturation.
double PoolRedPairShareOfThree(double saturation_a, double brightness_a, double saturation_b,
                               double brightness_b, const PoolTableProfile& profile,
                               PixelEncoding encoding);

// Assigns numbers to balls so that each number is used at most once and the sum of
// scores is largest (a ball stays unknown, -1, when no number scores over `unnamed_score`).
std::vector<int> AssignPoolNumbers(const std::vector<std::array<double, 10>>& scores,
                                   double unnamed_score = PoolBallOptions().unnamed_score);

// Figure 4.10: the image with every ball replaced by the cloth around it.
cv::Mat EmptyTableBackground(const cv::Mat& ideal_bgr, const cv::Matx33d& K,
                             const PlanarPose& pose, const PoolTableProfile& profile,
                             const std::vector<PoolDetectedBall>& balls);

// The silhouette of a sphere of `radius` at table point `centre` as a conic in ideal
// pixels: m^T Q m > 0 inside (with the sphere in front of the camera).
cv::Matx33d SphereSilhouetteConic(const PlanarPose& pose, const cv::Matx33d& K,
                                  const cv::Vec3d& centre, double radius);

}  // namespace texfree
