!> Volume, first and second moments of the body a bead model fills, in the shape's own length
!> unit: each bead centre stands for a lattice cell of volume d^3. Averaged over uniform
!> sub-lattice offsets, the lattice sums are exactly the body's integrals (the mean of
!> sum_n f(n + offset) over offsets is int f dV / d^3), so a few dozen cheap fills give the
!> continuum body's volume and moments without a formula for each shape (docs/theory.md T18).
module beadmob_body_moments
  use beadmob_kinds, only: dp, i8
  use beadmob_errors, only: error_t, raise
  use beadmob_lapack, only: dsyev
  implicit none
  private
  public :: body_moments_t, moments_of_beads, moments_of_polyhedron, moments_about_origin, equivalent_ellipsoid
  public :: unpacked_moments, packed_moments_size

  real(dp), parameter :: pi = acos(-1.0_dp)

  !> volume = N d^3, first = d^3 sum x, second = d^3 sum x x^T (x = centre * d, shape units).
  type :: body_moments_t
    real(dp) :: volume = 0.0_dp
    real(dp) :: first(3) = 0.0_dp
    real(dp) :: second(3, 3) = 0.0_dp
  contains
    procedure :: centroid
    procedure :: packed
  end type body_moments_t

  !> The moments as numbers: volume, first (3), second (9, column-major), as the result file,
  !> the checkpoint and the moment control's features hold them.
  integer, parameter :: packed_moments_size = 13

contains

  !> The moments of the beads at `centres` (in d) for a bead diameter d (shape units).
  pure function moments_of_beads(centres, d) result(moments)
    real(dp), intent(in) :: centres(:, :), d
    type(body_moments_t) :: moments
    integer(i8) :: i
    integer :: a, b
    do i = 1, size(centres, 2, kind=i8)
      moments%first = moments%first + centres(:, i)
      do b = 1, 3
        do a = 1, 3
          moments%second(a, b) = moments%second(a, b) + centres(a, i) * centres(b, i)
        end do
      end do
    end do
    moments%volume = size(centres, 2) * d**3
    moments%first = moments%first * d**4
    moments%second = moments%second * d**5
  end function moments_of_beads

  !> The exact moments of the solid a closed, outward-oriented triangle mesh bounds (vertices in
  !> the shape's unit), about `about` (e.g. a vertex: far-off coordinates then lose no digits):
  !> a sum over the tetrahedra (about, a, b, c) of signed volume v = det(a, b, c) / 6, first
  !> moment v (a + b + c) / 4 and second moment v / 20 (a a^T + b b^T + c c^T + s s^T),
  !> s = a + b + c (the tetrahedron's covariance, e.g. Tonon, J. Math. Stat. 1 (2005) 8-11).
  pure function moments_of_polyhedron(vertices, triangles, about) result(moments)
    real(dp), intent(in) :: vertices(:, :), about(3)
    integer, intent(in) :: triangles(:, :)
    type(body_moments_t) :: moments
    real(dp) :: a(3), b(3), c(3), s(3), v
    integer :: t, i, j
    do t = 1, size(triangles, 2)
      a = vertices(:, triangles(1, t)) - about
      b = vertices(:, triangles(2, t)) - about
      c = vertices(:, triangles(3, t)) - about
      v = dot_product(a, [b(2) * c(3) - b(3) * c(2), b(3) * c(1) - b(1) * c(3), b(1) * c(2) - b(2) * c(1)]) / 6.0_dp
      s = a + b + c
      moments%volume = moments%volume + v
      moments%first = moments%first + v * s / 4.0_dp
      do j = 1, 3
        do i = 1, 3
          moments%second(i, j) = moments%second(i, j) + v / 20.0_dp * (a(i) * a(j) + b(i) * b(j) + c(i) * c(j) + s(i) * s(j))
        end do
      end do
    end do
  end function moments_of_polyhedron

  !> Moments taken about `about` moved to the origin: x = y + about in V, int x, int x x^T.
  pure function moments_about_origin(moments, about) result(moved)
    type(body_moments_t), intent(in) :: moments
    real(dp), intent(in) :: about(3)
    type(body_moments_t) :: moved
    integer :: i, j
    moved%volume = moments%volume
    moved%first = moments%first + moments%volume * about
    do j = 1, 3
      do i = 1, 3
        moved%second(i, j) = moments%second(i, j) + about(i) * moments%first(j) + moments%first(i) * about(j) + &
                             moments%volume * about(i) * about(j)
      end do
    end do
  end function moments_about_origin

  pure function centroid(moments)
    class(body_moments_t), intent(in) :: moments
    real(dp) :: centroid(3)
    centroid = moments%first / moments%volume
  end function centroid

  pure function packed(moments) result(values)
    class(body_moments_t), intent(in) :: moments
    real(dp) :: values(packed_moments_size)
    values = [moments%volume, moments%first, reshape(moments%second, [9])]
  end function packed

  pure function unpacked_moments(values) result(moments)
    real(dp), intent(in) :: values(packed_moments_size)
    type(body_moments_t) :: moments
    moments = body_moments_t(values(1), values(2:4), reshape(values(5:13), [3, 3]))
  end function unpacked_moments

  !> The ellipsoid of the body's volume whose axes and proportions are those of its second
  !> moments about the centroid (a solid ellipsoid's are a_i^2 / 5 on its axes); `cell` is added
  !> to each moment per volume (d^2 / 12, a lattice cell's own, keeps a flat layer of beads
  !> from a zero axis). Axes: columns, in the shape's coordinates.
  subroutine equivalent_ellipsoid(moments, cell, semi_axes, axes, err)
    type(body_moments_t), intent(in) :: moments
    real(dp), intent(in) :: cell
    real(dp), intent(out) :: semi_axes(3), axes(3, 3)
    type(error_t), intent(inout) :: err
    real(dp) :: c(3), eigenvalues(3), work(64)
    integer :: info, k
    semi_axes = 0.0_dp
    if (.not. (moments%volume > 0.0_dp)) then
      call raise(err, 'equivalent ellipsoid: a body without volume')
      return
    end if
    c = moments%centroid()
    axes = moments%second / moments%volume
    do k = 1, 3
      axes(:, k) = axes(:, k) - c * c(k)
      axes(k, k) = axes(k, k) + cell
    end do
    call dsyev('V', 'U', 3, axes, 3, eigenvalues, work, size(work), info)
    if (info /= 0 .or. .not. all(eigenvalues > 0.0_dp)) then
      call raise(err, 'equivalent ellipsoid: the second moments are not positive')
      return
    end if
    semi_axes = sqrt(5.0_dp * eigenvalues)
    semi_axes = semi_axes * (3.0_dp * moments%volume / (4.0_dp * pi * product(semi_axes)))**(1.0_dp / 3.0_dp)
  end subroutine equivalent_ellipsoid
end module beadmob_body_moments
