!> From the 6x6 friction of a rigid body to its mobility and the paper's dimensionless
!> coefficients (settlers paper, eq. "matrices"): pi eta L mu_tt = diag(mu11, mu22, mu33),
!> pi eta L^2 mu_rt with mu42 (Omega_x from F_y) and mu51 (Omega_y from F_x), in the body frame,
!> about the centre of mass, z oriented so that theta = 0 is the stable orientation
!> (paper, eq. theta_51_exp: d theta/dt = mu51 sin theta, stable at 0 when mu51 < 0).
!> Units: eta = 1, lengths in bead diameters d.
module beadmob_mobility
  use beadmob_kinds, only: dp
  use beadmob_lapack, only: dgesv
  use beadmob_errors, only: error_t, raise
  use beadmob_strings, only: str
  implicit none
  private
  public :: mobility_result_t, compute_mobility, shifted, mobility_in_frame, coefficient_entries, coefficient_lengths, invert

  real(dp), parameter :: pi = acos(-1.0_dp)
  !> (row, column) of the body-frame mobility behind mu11, mu22, mu33, mu42, mu51 (rows and
  !> columns 1-3 translation / force, 4-6 rotation / torque)
  integer, parameter :: coefficient_entries(2, 5) = reshape([1, 1, 2, 2, 3, 3, 4, 2, 5, 1], [2, 5])

  type :: mobility_result_t
    real(dp) :: friction(6, 6) = 0.0_dp          ! model coordinates, about the reference point
    real(dp) :: mobility(6, 6) = 0.0_dp          ! inverse of friction
    real(dp) :: symmetry_error = 0.0_dp          ! ||zeta - zeta^T||_F / ||zeta||_F
    real(dp) :: body_axes(3, 3) = 0.0_dp         ! columns: body x, y, z (z possibly reversed)
    real(dp) :: body_mobility(6, 6) = 0.0_dp     ! mobility in the body frame
    real(dp) :: coefficients(5) = 0.0_dp         ! mu11, mu22, mu33, mu42, mu51
    real(dp) :: off_pattern = 0.0_dp             ! largest entry outside the paper's pattern, relative
    logical :: z_reversed = .false.              ! body y and z turned by pi about x for mu51 < 0
    !> Centre of mobility (model coordinates): the point about which the rotation-translation
    !> coupling is symmetric (Happel & Brenner 1965, sec. 5-5, for the analogous centre of
    !> reaction), and the mobility about it (model axes).
    real(dp) :: centre_of_mobility(3) = 0.0_dp
    real(dp) :: mobility_at_centre(6, 6) = 0.0_dp
  end type mobility_result_t

contains

  !> friction about reference_point (model coordinates); axes: columns = body axes.
  subroutine compute_mobility(friction, reference_point, axes, reference_length, result, err)
    real(dp), intent(in) :: friction(6, 6), reference_point(3), axes(3, 3), reference_length
    type(mobility_result_t), intent(out) :: result
    type(error_t), intent(inout) :: err
    real(dp) :: rotation(3, 3), tt(3, 3), rt(3, 3), pattern_max, other_max
    integer :: k

    result%friction = friction
    result%symmetry_error = norm2(friction - transpose(friction)) / norm2(friction)
    call invert(friction, result%mobility, err)
    if (err%failed) return

    call centre_of_mobility(result%mobility, reference_point, result%centre_of_mobility, result%mobility_at_centre, err)
    if (err%failed) return

    ! v_body = R v with R = axes^T; blocks transform as R M R^T.
    rotation = transpose(axes)
    result%body_mobility = in_frame(result%mobility, rotation)
    if (result%body_mobility(5, 1) > 0.0_dp) then
      ! Turning the frame by pi about x (y -> -y, z -> -z) reverses mu42 and mu51.
      result%z_reversed = .true.
      rotation(2:3, :) = -rotation(2:3, :)
      result%body_mobility = in_frame(result%mobility, rotation)
    end if
    result%body_axes = transpose(rotation)

    tt = pi * reference_length * result%body_mobility(1:3, 1:3)
    rt = pi * reference_length**2 * result%body_mobility(4:6, 1:3)
    do k = 1, 5
      result%coefficients(k) = coefficient_lengths(k, reference_length) * &
                               result%body_mobility(coefficient_entries(1, k), coefficient_entries(2, k))
    end do
    pattern_max = maxval(abs(result%coefficients))
    tt(1, 1) = 0.0_dp; tt(2, 2) = 0.0_dp; tt(3, 3) = 0.0_dp
    rt(1, 2) = 0.0_dp; rt(2, 1) = 0.0_dp
    other_max = max(maxval(abs(tt)), maxval(abs(rt)))
    result%off_pattern = other_max / pattern_max
  end subroutine compute_mobility

  !> The factor of coefficient k (mu11 ... mu51) on its mobility entry: pi eta L for mu_tt,
  !> pi eta L^2 for mu_rt (paper, eq. "matrices"; eta = 1).
  pure real(dp) function coefficient_lengths(k, reference_length)
    integer, intent(in) :: k
    real(dp), intent(in) :: reference_length
    coefficient_lengths = pi * reference_length**merge(1, 2, k <= 3)
  end function coefficient_lengths

  !> The mobility of `friction` in the frame whose columns are `axes` (e.g. another result's
  !> body_axes, so that two frictions of one body are compared entry by entry).
  subroutine mobility_in_frame(friction, axes, body_mobility, err)
    real(dp), intent(in) :: friction(6, 6), axes(3, 3)
    real(dp), intent(out) :: body_mobility(6, 6)
    type(error_t), intent(inout) :: err
    real(dp) :: mobility(6, 6)
    call invert(friction, mobility, err)
    if (.not. err%failed) body_mobility = in_frame(mobility, transpose(axes))
  end subroutine mobility_in_frame

  !> mobility = friction^-1 (any 6x6 matrix; `what` names it in the error, default the friction).
  subroutine invert(friction, mobility, err, what)
    real(dp), intent(in) :: friction(6, 6)
    real(dp), intent(out) :: mobility(6, 6)
    type(error_t), intent(inout) :: err
    character(len=*), intent(in), optional :: what
    real(dp) :: work(6, 6)
    integer :: pivots(6), info, k
    work = friction
    mobility = 0.0_dp
    do k = 1, 6
      mobility(k, k) = 1.0_dp
    end do
    call dgesv(6, 6, work, 6, pivots, mobility, 6, info)
    if (info /= 0 .and. present(what)) call raise(err, what // ' is singular (LAPACK dgesv info = ' // str(info) // ')')
    if (info /= 0 .and. .not. present(what)) &
      call raise(err, 'the 6x6 friction matrix is singular (LAPACK dgesv info = ' // str(info) // ')')
  end subroutine invert

  !> Moving the reference point by d: M(P) = A M A^T, A = [[I, -[d]x], [0, I]] (U_P = U_O + Omega x d,
  !> T_O = T_P + d x F), so the coupling becomes M_rt + M_rr [d]x. The centre of mobility makes it
  !> symmetric: three linear equations for d (the axial vector of the antisymmetric part = 0).
  subroutine centre_of_mobility(mobility, reference_point, centre, moved, err)
    real(dp), intent(in) :: mobility(6, 6), reference_point(3)
    real(dp), intent(out) :: centre(3), moved(6, 6)
    type(error_t), intent(inout) :: err
    real(dp) :: system(3, 3), rhs(3, 1), unit(3), d(3)
    integer :: k, pivots(3), info
    do k = 1, 3
      unit = 0.0_dp
      unit(k) = 1.0_dp
      system(:, k) = axial(matmul(mobility(4:6, 4:6), cross_matrix(unit)))
    end do
    rhs(:, 1) = -axial(mobility(4:6, 1:3))
    call dgesv(3, 1, system, 3, pivots, rhs, 3, info)
    if (info /= 0) then
      call raise(err, 'the centre of mobility is undefined (singular rotational mobility, LAPACK info = ' // str(info) // ')')
      return
    end if
    d = rhs(:, 1)
    centre = reference_point + d
    moved = shifted(mobility, d)
  end subroutine centre_of_mobility

  pure function shifted(mobility, d) result(moved)
    real(dp), intent(in) :: mobility(6, 6), d(3)
    real(dp) :: moved(6, 6), a(6, 6)
    integer :: k
    a = 0.0_dp
    do k = 1, 6
      a(k, k) = 1.0_dp
    end do
    a(1:3, 4:6) = -cross_matrix(d)
    moved = matmul(a, matmul(mobility, transpose(a)))
  end function shifted

  !> [v]x w = v x w
  pure function cross_matrix(v) result(m)
    real(dp), intent(in) :: v(3)
    real(dp) :: m(3, 3)
    m = reshape([0.0_dp, v(3), -v(2), -v(3), 0.0_dp, v(1), v(2), -v(1), 0.0_dp], [3, 3])
  end function cross_matrix

  !> Axial vector of the antisymmetric part of m.
  pure function axial(m) result(v)
    real(dp), intent(in) :: m(3, 3)
    real(dp) :: v(3)
    v = 0.5_dp * [m(3, 2) - m(2, 3), m(1, 3) - m(3, 1), m(2, 1) - m(1, 2)]
  end function axial

  pure function in_frame(matrix, rotation) result(rotated)
    real(dp), intent(in) :: matrix(6, 6), rotation(3, 3)
    real(dp) :: rotated(6, 6)
    integer :: row, column
    do column = 0, 1
      do row = 0, 1
        rotated(3 * row + 1:3 * row + 3, 3 * column + 1:3 * column + 3) = &
          matmul(rotation, matmul(matrix(3 * row + 1:3 * row + 3, 3 * column + 1:3 * column + 3), transpose(rotation)))
      end do
    end do
  end function in_frame
end module beadmob_mobility
