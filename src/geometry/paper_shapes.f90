!> Bead models of the particles of the settlers paper (appendix "Bead model of the particles
!> used in the experiments"): cone, arrowhead, open ring, crescent moon.
!> All sizes are in units of the bead diameter d = 1; bead centres sit on the integer cubic
!> lattice and are returned as built (not recentred), in the paper's body-frame orientation:
!> x along the larger in-plane size L, z along the height H (the cone axis), y the thin axis.
!> How the paper's text was read, which readings were tried and the counts obtained are in
!> shapes/README.md; the paper_* constants below are the values that reproduce the paper.
!> Boundary points: a lattice node lying on a surface in exact arithmetic is decided by an
!> explicit tolerance (see each builder), so the result does not depend on rounding.
!> On invalid parameters the builders call raise() and return centres of shape (3, 0).
module beadmob_paper_shapes
  use, intrinsic :: ieee_arithmetic, only: ieee_is_finite
  use beadmob_kinds, only: dp
  use beadmob_errors, only: error_t, raise
  use beadmob_strings, only: str
  use beadmob_size_checks, only: positive_size
  use beadmob_lattice_fill, only: lattice_nodes_inside, boundary_tolerance, reserve_sites, lattice_shift
  implicit none
  private
  public :: build_cone, build_arrowhead, build_open_ring, build_crescent_moon
  public :: gap_half_angle_from_arc, ellipse_gap_arc_length

  real(dp), parameter :: pi = acos(-1.0_dp)


  ! ---------------------------------------------------------------------------------------
  ! Paper parameters. Table tab_mob_num gives L/d; it equals the number of lattice columns
  ! along x (span of the centres + 1), so the centre-to-centre length is L/d - 1.
  ! ---------------------------------------------------------------------------------------

  !> Cone: L/d = 21 -> centre base diameter 21 - 1 = 20.
  real(dp), parameter, public :: paper_cone_base_diameter = 20.0_dp
  !> Cone height: floor(20 * H/L) = floor(20 * 10.45 mm / 4.39 mm) = floor(47.608) = 47.
  real(dp), parameter, public :: paper_cone_height = 47.0_dp
  !> Arrowhead: L/d = 29 -> centre length 28 (29 lattice columns). S and W are fixed by the
  !> count, 5104 = 29 * (W + 1) * S (every column holds S nodes in the half-open reading):
  !> S = 16 = floor(28 * 3.81 / 6.28), W = 10 = floor(28 * 2.33 / 6.28) (11 layers, 10.76
  !> rounded, with the table's scale 29 / 6.28 mm). H only tilts the wings, i.e. sets the
  !> couplings mu42, mu51: scaled with the table's L/d like the body length,
  !> H = round(29 * 4.93 / 6.28) = round(22.77) = 23 (the same beads as H = 22.77), which
  !> reproduces all five coefficients of Table tab_mob_num (bench/shape_readings/shape_readings.md; the
  !> earlier floor(28 * 4.93 / 6.28) = 21 missed mu42, mu51 by 33 %).
  real(dp), parameter, public :: paper_arrowhead_length = 28.0_dp
  real(dp), parameter, public :: paper_arrowhead_height = 23.0_dp
  real(dp), parameter, public :: paper_arrowhead_middle_height = 16.0_dp
  real(dp), parameter, public :: paper_arrowhead_width = 10.0_dp
  !> Open rings with gaps 1, 2, 3, 4 mm: a, b as listed in the appendix (items a-d).
  real(dp), parameter, public :: paper_ring_semi_major(4) = [30.90_dp, 33.72_dp, 37.08_dp, 39.06_dp]
  real(dp), parameter, public :: paper_ring_semi_minor(4) = [27.90_dp, 27.60_dp, 27.48_dp, 27.36_dp]
  !> The appendix lists the gap half-angles 10 deg 47', 20 deg 32', 28 deg 30', 36 deg 35' (items
  !> a-d); the model uses the angles below instead (bench/shape_readings/shape_readings.md runs both).
  !> Measured openings (section "Rigid particles": 1.02, 2.02, 3.02, 4.02 mm) and the scale
  !> 12 d/mm: the listed arcs of the 3 and 4 mm rings are 36.23 = 12 x 3.02 and 48.24 =
  !> 12 x 4.02 d (and 2R = 7.2 d for the width 0.596 mm is 12.1 d/mm). The gap arc of every
  !> ring is 12 d/mm x its opening (appendix: the arc length fixes Delta-theta).
  real(dp), parameter, public :: paper_ring_gap_mm(4) = [1.02_dp, 2.02_dp, 3.02_dp, 4.02_dp]
  real(dp), parameter, public :: paper_ring_d_per_mm = 12.0_dp
  real(dp), parameter, public :: paper_ring_gap_arc_length(4) = paper_ring_d_per_mm * paper_ring_gap_mm
  !> Gap half-angles of those arcs, gap_half_angle_from_arc(a, b, 12 x opening) in degrees (the
  !> test checks it): 11 deg 22', 20 deg 44', 28 deg 31', 36 deg 35'. The 3 and 4 mm rings keep
  !> the listed angles' beads; 1 and 2 mm get wider gaps, which brings their mu42, mu51 within
  !> 3 % of the table but ring 1 mm's mu51 (+3.8 %); with the listed angles they missed by 8-10 %
  !> and 3 %. No single gap rule tried fits all 20 ring coefficients (bench/shape_readings/shape_readings.md).
  real(dp), parameter, public :: paper_ring_gap_half_angle_deg(4) = &
    [11.361565167835_dp, 20.740409759798_dp, 28.511889540928_dp, 36.582314683360_dp]
  !> Pipe radius of the paper, R = 3.6.
  real(dp), parameter, public :: paper_ring_tube_radius = 3.6_dp
  !> Radius passed to build_open_ring: R - d/2 = 3.1 (whole bead inside the pipe); this
  !> is the reading nearest to the paper's counts (shapes/README.md), R = 3.6 itself gives ~7100 beads.
  real(dp), parameter, public :: paper_ring_pipe_radius = paper_ring_tube_radius - 0.5_dp
  !> Crescent moon: s = 6.2, epsilon = 0.6 (appendix "Crescent Moon").
  real(dp), parameter, public :: paper_crescent_scale = 6.2_dp
  real(dp), parameter, public :: paper_crescent_section_ratio = 0.6_dp
  !> L/d of table tab_mob_num (the mobilities' reference length).
  real(dp), parameter, public :: paper_cone_reference_length = 21.0_dp
  real(dp), parameter, public :: paper_arrowhead_reference_length = 29.0_dp
  real(dp), parameter, public :: paper_crescent_reference_length = 55.0_dp
  real(dp), parameter, public :: paper_ring_reference_length(4) = [67.0_dp, 73.0_dp, 81.0_dp, 85.0_dp]
  !> Samples of the ellipse parameter for the nearest-point search (then refined).
  integer, parameter :: ellipse_samples = 7200
  !> Samples of the curve parameter p for the crescent's z_min(x), z_max(x) (then bisected).
  integer, parameter :: curve_samples = 4096

contains

  ! ---------------------------------------------------------------------------------------
  !> Cone (appendix "Cone"): lattice nodes with 0 <= z <= H and r <= R(z) = (H - z) L / (2H),
  !> r the distance from the axis; a lattice node on the axis, base at z = 0.
  !> Both inequalities are inclusive ("including its surface"): nodes on the surface (for the
  !> paper values the 12 nodes with r = 10 at z = 0 and the apex) are kept, with an absolute
  !> tolerance boundary_tolerance * max(1, L).
  subroutine build_cone(base_diameter, height, centres, err, offset)
    real(dp), intent(in) :: base_diameter, height
    real(dp), allocatable, intent(out) :: centres(:, :)
    real(dp), intent(in), optional :: offset(3)
    type(error_t), intent(inout) :: err
    real(dp) :: tol
    integer :: n_r, n_z

    allocate (centres(3, 0))
    if (.not. positive_size(base_diameter, 'cone: base_diameter', err)) return
    if (.not. positive_size(height, 'cone: height', err)) return
    tol = boundary_tolerance * max(1.0_dp, base_diameter, height)
    n_r = floor(0.5_dp * base_diameter + tol)
    n_z = floor(height + tol)
    call lattice_nodes_inside([-n_r, -n_r, 0], [n_r, n_r, n_z], inside_cone, 'cone', lattice_shift(offset), centres, err)
  contains
    logical function inside_cone(node)
      real(dp), intent(in) :: node(3)
      real(dp) :: r_max
      r_max = (height - node(3)) * base_diameter / (2.0_dp * height)  ! R(z), appendix "Cone"
      inside_cone = sqrt(node(1)**2 + node(2)**2) <= r_max + tol .and. node(3) >= -tol .and. node(3) <= height + tol
    end function inside_cone
  end subroutine build_cone

  ! ---------------------------------------------------------------------------------------
  !> Arrowhead (appendix "Arrowhead"): lattice with a node at (0,0,0); keep nodes with
  !> |x| <= L/2, 0 <= y <= W and k|x| <= z < S + k|x|, slope k = (H - S) / (L/2).
  !> The upper bound is half-open (the paper writes <=): every column (x, y) then holds
  !> exactly S lattice nodes for integer S, which is what gives the paper's count
  !> 29 * 11 * 16 = 5104 (the inclusive reading gives 5137, see shapes/README.md).
  !> Nodes on the lower surface or on |x| = L/2, y = 0, y = W are kept; nodes on the upper
  !> surface are not; tolerance boundary_tolerance * max(1, L, H).
  subroutine build_arrowhead(length, height, middle_height, width, centres, err, offset)
    real(dp), intent(in) :: length, height, middle_height, width
    real(dp), allocatable, intent(out) :: centres(:, :)
    type(error_t), intent(inout) :: err
    real(dp), intent(in), optional :: offset(3)   ! of the lattice against the body (lattice_nodes_inside)
    real(dp), allocatable :: buffer(:, :)
    real(dp) :: tol, slope, z_low, shift(3), point(3)
    integer :: n_x, n_y, n_z, i, j, k, count, widen

    allocate (centres(3, 0))
    if (.not. positive_size(length, 'arrowhead: length', err)) return
    if (.not. positive_size(height, 'arrowhead: height', err)) return
    if (.not. positive_size(middle_height, 'arrowhead: middle_height', err)) return
    if (.not. positive_size(width, 'arrowhead: width', err)) return
    if (middle_height > height) then
      call raise(err, 'arrowhead: middle_height must not exceed height, got ' &
                 // str(middle_height) // ' > ' // str(height))
      return
    end if
    tol = boundary_tolerance * max(1.0_dp, length, height)
    slope = (height - middle_height) / (0.5_dp * length)  ! k = (H - S) / (L/2)
    n_x = floor(0.5_dp * length + tol)
    n_y = floor(width + tol)
    n_z = ceiling(height) + 1
    shift = lattice_shift(offset)
    widen = merge(1, 0, any(shift /= 0.0_dp))   ! a shifted lattice: one more node below each range
    call reserve_sites([2 * n_x + 1, n_y + 1, n_z + 1] + widen, 'arrowhead', buffer, err)
    if (err%failed) return
    count = 0
    do i = -n_x - widen, n_x
      point(1) = i + shift(1)
      if (abs(point(1)) > 0.5_dp * length + tol) cycle
      z_low = slope * abs(point(1))
      do j = -widen, n_y
        point(2) = j + shift(2)
        if (point(2) < -tol .or. point(2) > width + tol) cycle
        do k = -widen, n_z
          point(3) = k + shift(3)
          if (point(3) >= z_low - tol .and. point(3) < z_low + middle_height - tol) then
            count = count + 1
            buffer(:, count) = point
          end if
        end do
      end do
    end do
    deallocate (centres)
    centres = buffer(:, 1:count)
  end subroutine build_arrowhead

  ! ---------------------------------------------------------------------------------------
  !> Open ring (appendix "Open Ring"): pipe of radius pipe_radius around the ellipse
  !> r(theta) = (a cos theta, b sin theta, 0); keep lattice nodes (node at the ellipse centre)
  !> whose distance to the ellipse is < pipe_radius, then remove those whose nearest ellipse
  !> point has theta* in [90 deg - gap, 90 deg + gap].
  !> The nearest point is found on 7200 samples of theta and refined by golden-section search.
  !> The distance test is strict with a relative margin (dist**2 < R**2 (1 - 1e-9)): for the
  !> 1 mm paper ring the nodes (+-34, 0, 0) lie exactly at distance 3.1 and are dropped, which
  !> gives 67 columns along x as in the paper's table (L/d = 67). The gap test is inclusive
  !> (margin 1e-9 rad); nodes on the minor axis above the centre have theta* = 90 deg exactly.
  !> Output is rotated (x, y, z) -> (x, -z, y): ellipse in the xz plane, semi-major axis along
  !> x, gap on the +z axis, pipe thickness along y.
  !> For the paper's rings pass pipe_radius = paper_ring_pipe_radius (R - d/2, see shapes/README.md).
  subroutine build_open_ring(semi_major, semi_minor, pipe_radius, gap_half_angle_deg, centres, err, offset)
    real(dp), intent(in) :: semi_major, semi_minor, pipe_radius, gap_half_angle_deg
    real(dp), allocatable, intent(out) :: centres(:, :)
    type(error_t), intent(inout) :: err
    real(dp), intent(in), optional :: offset(3)   ! of the lattice against the body, output frame
    real(dp), allocatable :: buffer(:, :)
    real(dp) :: gap, dist2, theta_star, off_gap, r2_max, rho, shift(3), x, y, z
    real(dp), allocatable :: samples(:, :)   ! 115 kB: on the heap, not in static storage
    integer :: n_x, n_y, n_z, i, j, k, count, widen, m

    allocate (centres(3, 0))
    if (.not. positive_size(semi_major, 'open_ring: semi_major', err)) return
    if (.not. positive_size(semi_minor, 'open_ring: semi_minor', err)) return
    if (.not. positive_size(pipe_radius, 'open_ring: pipe_radius', err)) return
    if (semi_minor > semi_major) then
      call raise(err, 'open_ring: semi_minor must not exceed semi_major, got ' &
                 // str(semi_minor) // ' > ' // str(semi_major))
      return
    end if
    if (.not. ieee_is_finite(gap_half_angle_deg)) then
      call raise(err, 'open_ring: gap_half_angle_deg must be finite, got ' // str(gap_half_angle_deg))
      return
    end if
    if (gap_half_angle_deg < 0.0_dp .or. gap_half_angle_deg >= 180.0_dp) then
      call raise(err, 'open_ring: gap_half_angle_deg must be in [0, 180), got ' &
                 // str(gap_half_angle_deg))
      return
    end if
    gap = gap_half_angle_deg * pi / 180.0_dp
    r2_max = pipe_radius**2 * (1.0_dp - boundary_tolerance)
    n_x = ceiling(semi_major + pipe_radius)
    n_y = ceiling(semi_minor + pipe_radius)
    n_z = ceiling(pipe_radius)
    ! The output (x, -z, y) is shifted by `offset`: in the ring's own frame x by offset(1), y by
    ! offset(3) and z by -offset(2); a shifted lattice needs one more node at each end.
    shift = lattice_shift(offset)
    widen = merge(1, 0, any(shift /= 0.0_dp))
    call reserve_sites([2 * n_x + 1, 2 * n_y + 1, 2 * n_z + 1] + 2 * widen, 'open_ring', buffer, err)
    if (err%failed) return
    ! The ellipse's sample points, once for all lattice points (the same numbers as evaluated per point).
    allocate (samples(2, 0:ellipse_samples - 1))
    do m = 0, ellipse_samples - 1
      samples(:, m) = [semi_major * cos(m * (2.0_dp * pi / ellipse_samples)), &
                       semi_minor * sin(m * (2.0_dp * pi / ellipse_samples))]
    end do
    count = 0
    do j = -n_y - widen, n_y + widen
      y = j + shift(3)
      do i = -n_x - widen, n_x + widen
        x = i + shift(1)
        ! cheap rejection: every ellipse point has radius in [b, a]
        rho = sqrt(x**2 + y**2)
        if (max(semi_minor - rho, rho - semi_major) >= pipe_radius) cycle
        call nearest_on_ellipse(semi_major, semi_minor, samples, x, y, dist2, theta_star)
        if (dist2 >= r2_max) cycle
        ! angular distance of theta* from theta_0 = 90 deg, wrapped to [0, pi]
        off_gap = abs(modulo(theta_star - 0.5_dp * pi + pi, 2.0_dp * pi) - pi)
        if (off_gap <= gap + boundary_tolerance) cycle
        do k = -n_z - widen, n_z + widen
          z = k - shift(2)
          if (dist2 + z**2 < r2_max) then
            count = count + 1
            buffer(:, count) = [x, -z, y]  ! (x, -z, y)
          end if
        end do
      end do
    end do
    deallocate (centres)
    centres = buffer(:, 1:count)
  end subroutine build_open_ring

  !> Squared distance from (px, py) to the ellipse (a cos t, b sin t) and the parameter
  !> t in [0, 2 pi) of the nearest point: best of ellipse_samples samples (`samples`: the points
  !> (a cos t_m, b sin t_m), t_m = 2 pi m / ellipse_samples), then golden-section search on the
  !> bracketing interval (appendix "Open Ring": discretised theta).
  pure subroutine nearest_on_ellipse(a, b, samples, px, py, dist2, theta)
    real(dp), intent(in) :: a, b, samples(2, 0:ellipse_samples - 1), px, py
    real(dp), intent(out) :: dist2, theta
    real(dp), parameter :: golden = 0.5_dp * (sqrt(5.0_dp) - 1.0_dp)
    real(dp) :: h, t, d, lo, hi, t1, t2, d1, d2
    integer :: m, it
    h = 2.0_dp * pi / ellipse_samples
    dist2 = huge(1.0_dp)
    theta = 0.0_dp
    do m = 0, ellipse_samples - 1
      d = (samples(1, m) - px)**2 + (samples(2, m) - py)**2
      if (d < dist2) then
        dist2 = d
        theta = m * h
      end if
    end do
    lo = theta - h
    hi = theta + h
    t1 = hi - golden * (hi - lo)
    t2 = lo + golden * (hi - lo)
    d1 = (a * cos(t1) - px)**2 + (b * sin(t1) - py)**2
    d2 = (a * cos(t2) - px)**2 + (b * sin(t2) - py)**2
    do it = 1, 100
      if (d1 < d2) then
        hi = t2
        t2 = t1
        d2 = d1
        t1 = hi - golden * (hi - lo)
        d1 = (a * cos(t1) - px)**2 + (b * sin(t1) - py)**2
      else
        lo = t1
        t1 = t2
        d1 = d2
        t2 = lo + golden * (hi - lo)
        d2 = (a * cos(t2) - px)**2 + (b * sin(t2) - py)**2
      end if
      if (hi - lo < 1.0e-15_dp) exit
    end do
    t = 0.5_dp * (lo + hi)
    d = (a * cos(t) - px)**2 + (b * sin(t) - py)**2
    if (d < dist2) then
      dist2 = d
      theta = t
    end if
    theta = modulo(theta, 2.0_dp * pi)
  end subroutine nearest_on_ellipse

  !> Arc length of the ellipse (a cos t, b sin t) between 90 deg - half_angle and
  !> 90 deg + half_angle (appendix "Open Ring": integral of sqrt(a^2 sin^2 + b^2 cos^2)),
  !> composite Simpson rule on 4000 intervals (the integrand is smooth). half_angle in degrees.
  pure real(dp) function ellipse_gap_arc_length(semi_major, semi_minor, half_angle_deg) result(arc)
    real(dp), intent(in) :: semi_major, semi_minor, half_angle_deg
    integer, parameter :: n = 4000
    real(dp) :: half, h, t, w
    integer :: m
    half = half_angle_deg * pi / 180.0_dp
    h = 2.0_dp * half / n
    arc = 0.0_dp
    do m = 0, n
      t = 0.5_dp * pi - half + m * h
      if (m == 0 .or. m == n) then
        w = 1.0_dp
      else if (mod(m, 2) == 1) then
        w = 4.0_dp
      else
        w = 2.0_dp
      end if
      arc = arc + w * sqrt((semi_major * sin(t))**2 + (semi_minor * cos(t))**2)
    end do
    arc = arc * h / 3.0_dp
  end function ellipse_gap_arc_length

  !> Gap half-angle Delta-theta in degrees whose arc, centred on theta_0 = 90 deg, has length
  !> gap_arc_length (appendix "Open Ring", solved by bisection as in the paper).
  !> Invalid input (non-positive sizes, arc length not in (0, perimeter)) raises on err if
  !> present and returns 0.
  real(dp) function gap_half_angle_from_arc(semi_major, semi_minor, gap_arc_length, err) &
    result(half_angle_deg)
    real(dp), intent(in) :: semi_major, semi_minor, gap_arc_length
    type(error_t), intent(inout), optional :: err
    real(dp) :: lo, hi, mid, perimeter
    integer :: it
    type(error_t) :: local_err
    half_angle_deg = 0.0_dp
    if (.not. positive_size(semi_major, 'gap_half_angle_from_arc: semi_major', local_err) .or. &
        .not. positive_size(semi_minor, 'gap_half_angle_from_arc: semi_minor', local_err) .or. &
        .not. positive_size(gap_arc_length, 'gap_half_angle_from_arc: gap_arc_length', local_err)) then
      if (present(err)) call raise(err, local_err%message)
      return
    end if
    perimeter = ellipse_gap_arc_length(semi_major, semi_minor, 180.0_dp)
    if (gap_arc_length >= perimeter) then
      if (present(err)) call raise(err, 'gap_half_angle_from_arc: gap_arc_length must be below ' &
                                   // 'the perimeter ' // str(perimeter) // ', got ' // str(gap_arc_length))
      return
    end if
    lo = 0.0_dp
    hi = 180.0_dp
    do it = 1, 200
      mid = 0.5_dp * (lo + hi)
      if (ellipse_gap_arc_length(semi_major, semi_minor, mid) < gap_arc_length) then
        lo = mid
      else
        hi = mid
      end if
      if (hi - lo < 1.0e-13_dp) exit
    end do
    half_angle_deg = 0.5_dp * (lo + hi)
  end function gap_half_angle_from_arc

  ! ---------------------------------------------------------------------------------------
  !> Crescent moon (appendix "Crescent Moon", s = scale, epsilon = section_ratio):
  !> reference curve x(p) = eta_x (5 cos p - sin 2p), z(p) = eta_z (3 sin p + 2 cos 2p),
  !> eta_x = 0.84 s, eta_z = 0.51 s. At every integer x crossed by the curve, z_min(x) and
  !> z_max(x) are the extreme z of all crossings (found exactly: sign changes of x(p) - x on
  !> 4096 samples of p, then bisection). Keep integer lattice nodes (x, y, z) with
  !>   (y / b)**2 + ((z - z_m) / a)**2 <= 1, z_m = (z_min + z_max)/2, a = (z_max - z_min)/2,
  !>   b = epsilon a;
  !>   outside both holes (x - x_c)**2 + (z - z_c)**2 <= (0.4 s)**2, (x_c, z_c) =
  !>   (+-1.823 s, -0.548 s) (a node on a hole's surface is removed);
  !>   |y| <= 19/40 b - 7/20 epsilon z (between the two planes y_-, y_+).
  !> Inclusive tests with a margin boundary_tolerance * max(1, s) (no node of the paper's
  !> model is closer than 0.007 to a surface). An integer x that only touches the curve
  !> (double root, no sign change) is not detected: it does not occur for s = 6.2.
  subroutine build_crescent_moon(scale, section_ratio, centres, err, offset)
    real(dp), intent(in) :: scale, section_ratio
    real(dp), allocatable, intent(out) :: centres(:, :)
    type(error_t), intent(inout) :: err
    real(dp), intent(in), optional :: offset(3)   ! of the lattice against the body (lattice_nodes_inside)
    real(dp), allocatable :: buffer(:, :)
    real(dp) :: eta_x, eta_z, tol, z_min, z_max, z_mid, semi_a, semi_b, x, y, z
    real(dp) :: hole_x, hole_z, hole_r
    real(dp) :: shift(3)
    logical :: found
    integer :: n_x, n_y, n_z, i, j, k, count, widen

    allocate (centres(3, 0))
    if (.not. positive_size(scale, 'crescent_moon: scale', err)) return
    if (.not. ieee_is_finite(section_ratio) .or. section_ratio <= 0.0_dp .or. section_ratio > 1.0_dp) then
      call raise(err, 'crescent_moon: section_ratio must be in (0, 1], got ' // str(section_ratio))
      return
    end if
    eta_x = 0.84_dp * scale
    eta_z = 0.51_dp * scale
    hole_x = 1.823_dp * scale
    hole_z = -0.548_dp * scale
    hole_r = 0.4_dp * scale
    tol = boundary_tolerance * max(1.0_dp, scale)
    n_x = ceiling(6.0_dp * eta_x)          ! |5 cos p - sin 2p| <= 6
    n_z = ceiling(7.0_dp * eta_z) + 1      ! |3 sin p + 2 cos 2p| <= 5 < 7
    n_y = ceiling(section_ratio * n_z) + 1
    shift = lattice_shift(offset)
    widen = merge(1, 0, any(shift /= 0.0_dp))   ! a shifted lattice: one more node at each end
    call reserve_sites([2 * n_x + 1, 2 * n_y + 1, 2 * n_z + 1] + 2 * widen, 'crescent_moon', buffer, err)
    if (err%failed) return
    count = 0
    do i = -n_x - widen, n_x + widen
      x = i + shift(1)
      call curve_z_range(eta_x, eta_z, x, z_min, z_max, found)
      if (.not. found) cycle
      z_mid = 0.5_dp * (z_min + z_max)
      semi_a = 0.5_dp * (z_max - z_min)
      semi_b = section_ratio * semi_a
      if (semi_a <= tol) cycle
      do k = -n_z - widen, n_z + widen
        z = k + shift(3)
        ! holes: cylinders along y through (+-x_c, z_c), radius 0.4 s
        if ((x - hole_x)**2 + (z - hole_z)**2 <= hole_r**2 + tol) cycle
        if ((x + hole_x)**2 + (z - hole_z)**2 <= hole_r**2 + tol) cycle
        do j = -n_y - widen, n_y + widen
          y = j + shift(2)
          if ((y / semi_b)**2 + ((z - z_mid) / semi_a)**2 > 1.0_dp + tol) cycle
          ! planes: y_- <= y <= y_+, y_-+ = +-(7/20) eps z -+ (19/40) b
          if (abs(y) > 19.0_dp / 40.0_dp * semi_b - 7.0_dp / 20.0_dp * section_ratio * z + tol) cycle
          count = count + 1
          buffer(:, count) = [x, y, z]
        end do
      end do
    end do
    deallocate (centres)
    centres = buffer(:, 1:count)
  end subroutine build_crescent_moon

  !> Extreme z of the crossings of the crescent's reference curve with the line x = x0.
  pure subroutine curve_z_range(eta_x, eta_z, x0, z_min, z_max, found)
    real(dp), intent(in) :: eta_x, eta_z, x0
    real(dp), intent(out) :: z_min, z_max
    logical, intent(out) :: found
    real(dp) :: h, p0, p1, f0, f1, lo, hi, mid, fm, zc
    integer :: m, it
    h = 2.0_dp * pi / curve_samples
    found = .false.
    z_min = huge(1.0_dp)
    z_max = -huge(1.0_dp)
    do m = 0, curve_samples - 1
      p0 = m * h
      p1 = (m + 1) * h
      f0 = curve_x(p0) - x0
      f1 = curve_x(p1) - x0
      if (abs(f0) <= 0.0_dp) then  ! the sample is exactly on the line x = x0
        zc = curve_z(p0)
      else if (f0 * f1 < 0.0_dp) then
        lo = p0
        hi = p1
        do it = 1, 200
          mid = 0.5_dp * (lo + hi)
          fm = curve_x(mid) - x0
          if (fm * f0 > 0.0_dp) then
            lo = mid
          else
            hi = mid
          end if
          if (hi - lo < 1.0e-15_dp) exit
        end do
        zc = curve_z(0.5_dp * (lo + hi))
      else
        cycle
      end if
      found = .true.
      z_min = min(z_min, zc)
      z_max = max(z_max, zc)
    end do
  contains
    pure real(dp) function curve_x(p)
      real(dp), intent(in) :: p
      curve_x = eta_x * (5.0_dp * cos(p) - sin(2.0_dp * p))
    end function curve_x
    pure real(dp) function curve_z(p)
      real(dp), intent(in) :: p
      curve_z = eta_z * (3.0_dp * sin(p) + 2.0_dp * cos(2.0_dp * p))
    end function curve_z
  end subroutine curve_z_range

end module beadmob_paper_shapes
