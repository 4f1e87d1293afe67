!> The error bar of a run (docs/theory.md T14): its truncation error estimated from the
!> difference between its order-L mobility and the companion's of order L - 1 on the same beads,
!> and a value extrapolated in L with its own error, both from this run alone.
!>
!> Measure: entry (i, j) of the 6x6 body-frame mobility M is measured on the scale
!> sqrt(M_ii M_jj), the largest |M_ij| a positive definite matrix allows there: relative on the
!> diagonal, and for a coupling near zero on the scale of its block rather than its own value.
!> With the step s_ij = |M_ij(L) - M_ij(L - 1)| / sqrt(M_ii M_jj) and b_ij the largest step in
!> the 3x3 block of (i, j):
!>   estimated error      e_ij = max(entry_factor s_ij, block_factor b_ij)
!>   extrapolated value   M_ij(L) + extrapolation_ratio (M_ij(L) - M_ij(L - 1))
!>   its estimated error  max(extrapolated_entry_factor s_ij, extrapolated_block_factor b_ij).
!> The factors were fitted on bodies outside the validation set (bench/error_estimate/error_estimate.py
!> calibrate) against L = 4, full-model references, and are checked on the paper's shapes and
!> others in bench/error_estimate/error_estimate.md; they hold for the default settings' kind of run (the
!> shell model and Krylov tolerance enter the fitted errors).
module beadmob_error_estimate
  use beadmob_kinds, only: dp
  use beadmob_mobility, only: coefficient_entries, coefficient_lengths
  implicit none
  private
  public :: error_estimate_t, estimate_error, entry_factor, block_factor, extrapolation_ratio, &
            extrapolated_entry_factor, extrapolated_block_factor, add_operator_error

  ! bench/error_estimate/error_estimate.md, "Calibration" (fitted on the tuning bodies only).
  real(dp), parameter :: entry_factor = 0.6_dp
  real(dp), parameter :: block_factor = 0.03_dp
  real(dp), parameter :: extrapolation_ratio = 0.15_dp
  real(dp), parameter :: extrapolated_entry_factor = 0.4_dp
  real(dp), parameter :: extrapolated_block_factor = 0.03_dp

  type :: error_estimate_t
    logical :: available = .false.
    integer :: companion_order = 0
    real(dp) :: companion_mobility(6, 6) = 0.0_dp      ! body frame, order L - 1
    real(dp) :: companion_coefficients(5) = 0.0_dp
    real(dp) :: mobility_error(6, 6) = 0.0_dp          ! estimated |M(L) - M|, body frame
    real(dp) :: scaled_mobility_error(6, 6) = 0.0_dp   ! the same in the measure above
    real(dp) :: coefficient_error(5) = 0.0_dp          ! of mu11 ... mu51, absolute
    real(dp) :: scaled_coefficient_error(5) = 0.0_dp   ! of mu11 ... mu51, in the measure above
    real(dp) :: extrapolated_mobility(6, 6) = 0.0_dp
    real(dp) :: extrapolated_coefficients(5) = 0.0_dp
    real(dp) :: extrapolated_coefficient_error(5) = 0.0_dp
    real(dp) :: scaled_extrapolated_coefficient_error(5) = 0.0_dp
    real(dp) :: scaled_extrapolated_mobility_error(6, 6) = 0.0_dp
    real(dp) :: largest = 0.0_dp                ! max over the 36 entries of the scaled error
    real(dp) :: largest_extrapolated = 0.0_dp
    !> The truncation's part alone (the companion's step) when an approximate operator's error
    !> was added (add_operator_error); otherwise equal to largest
    real(dp) :: largest_truncation = 0.0_dp
  end type error_estimate_t

contains

  !> body_mobility: order L; companion_body_mobility: order L - 1, in the same body frame;
  !> reference_length: L of the paper's coefficients (mobility.f90).
  pure function estimate_error(body_mobility, companion_body_mobility, reference_length, companion_order) &
    result(estimate)
    real(dp), intent(in) :: body_mobility(6, 6), companion_body_mobility(6, 6), reference_length
    integer, intent(in) :: companion_order
    type(error_estimate_t) :: estimate
    real(dp) :: scale(6, 6), step(6, 6), block(6, 6), extrapolated_scaled(6, 6), diagonal(6)
    integer :: i, j, k

    diagonal = [(sqrt(abs(body_mobility(i, i))), i = 1, 6)]
    scale = spread(diagonal, 2, 6) * spread(diagonal, 1, 6)
    step = abs(body_mobility - companion_body_mobility) / scale
    do j = 1, 6
      do i = 1, 6
        block(i, j) = maxval(step(3 * ((i - 1) / 3) + 1:3 * ((i - 1) / 3) + 3, 3 * ((j - 1) / 3) + 1:3 * ((j - 1) / 3) + 3))
      end do
    end do
    estimate%available = .true.
    estimate%companion_order = companion_order
    estimate%companion_mobility = companion_body_mobility
    estimate%scaled_mobility_error = max(entry_factor * step, block_factor * block)
    estimate%mobility_error = estimate%scaled_mobility_error * scale
    estimate%extrapolated_mobility = body_mobility + extrapolation_ratio * (body_mobility - companion_body_mobility)
    extrapolated_scaled = max(extrapolated_entry_factor * step, extrapolated_block_factor * block)
    estimate%largest = maxval(estimate%scaled_mobility_error)
    estimate%largest_truncation = estimate%largest
    estimate%scaled_extrapolated_mobility_error = extrapolated_scaled
    estimate%largest_extrapolated = maxval(extrapolated_scaled)
    do k = 1, 5
      i = coefficient_entries(1, k)
      j = coefficient_entries(2, k)
      estimate%companion_coefficients(k) = coefficient_lengths(k, reference_length) * companion_body_mobility(i, j)
      estimate%extrapolated_coefficients(k) = coefficient_lengths(k, reference_length) * &
                                              estimate%extrapolated_mobility(i, j)
      estimate%scaled_coefficient_error(k) = estimate%scaled_mobility_error(i, j)
      estimate%coefficient_error(k) = coefficient_lengths(k, reference_length) * estimate%mobility_error(i, j)
      estimate%scaled_extrapolated_coefficient_error(k) = extrapolated_scaled(i, j)
      estimate%extrapolated_coefficient_error(k) = coefficient_lengths(k, reference_length) * &
                                                   extrapolated_scaled(i, j) * scale(i, j)
    end do
  end function estimate_error

  !> The error bar of a run whose operator approximates the Galerkin matrix (the pfft far field,
  !> theory.md T16): its bound, entry by entry in the same measure (scaled_error, on the scale
  !> sqrt(M_ii M_jj) of body_mobility), added to the truncation's estimate and to the
  !> extrapolated value's error (the extrapolation in L does not remove it).
  pure subroutine add_operator_error(estimate, scaled_error, body_mobility, reference_length)
    type(error_estimate_t), intent(inout) :: estimate
    real(dp), intent(in) :: scaled_error(6, 6), body_mobility(6, 6), reference_length
    real(dp) :: scale(6, 6), diagonal(6)
    integer :: i, j, k
    diagonal = [(sqrt(abs(body_mobility(i, i))), i = 1, 6)]
    scale = spread(diagonal, 2, 6) * spread(diagonal, 1, 6)
    estimate%scaled_mobility_error = estimate%scaled_mobility_error + scaled_error
    estimate%mobility_error = estimate%scaled_mobility_error * scale
    estimate%scaled_extrapolated_mobility_error = estimate%scaled_extrapolated_mobility_error + scaled_error
    estimate%largest = maxval(estimate%scaled_mobility_error)
    estimate%largest_extrapolated = maxval(estimate%scaled_extrapolated_mobility_error)
    do k = 1, 5
      i = coefficient_entries(1, k)
      j = coefficient_entries(2, k)
      estimate%scaled_coefficient_error(k) = estimate%scaled_mobility_error(i, j)
      estimate%coefficient_error(k) = coefficient_lengths(k, reference_length) * estimate%mobility_error(i, j)
      estimate%scaled_extrapolated_coefficient_error(k) = estimate%scaled_extrapolated_mobility_error(i, j)
      estimate%extrapolated_coefficient_error(k) = coefficient_lengths(k, reference_length) * &
                                                   estimate%scaled_extrapolated_mobility_error(i, j) * scale(i, j)
    end do
  end subroutine add_operator_error
end module beadmob_error_estimate
