!> The approximate operator's part of a run's error bar (docs/theory.md T16, "The far field's
!> error in every run"). The sampled rows (operator_error.F90) give for each row k two 6x6 terms:
!> t_k, its part of the first-order change of the friction, and w_k, its part of
!> (E q_m) . S^-1 (E q_n), S the single-bead block. The change of the friction is
!>   zeta(A) - zeta(A~) = -q^T E q + (E q)^T A^-1 (E q) + O(E^3)   (E = A - A~, q = A~^-1 c),
!> whose second term is positive semi-definite and, E q being rough from bead to bead (the
!> interpolation error of each bead's own stencil), about rho (E q)^T S^-1 (E q) with rho between
!> 1/lambda_max and 1/lambda_min of S^-1 A (about 0.03 and 10-17): measured 0.5-3.9
!> (bench/error_estimate/operator_error.md), so it is taken as second_order_mid W with an allowance
!> of second_order_half W (rho in 0 .. 5).
!> Draw by draw (bead i_k drawn with probability p_k), in the body frame of the mobility
!> (dM = -M dzeta M to first order in dzeta):
!>   u_k = -M (t_k + second_order_mid w_k) M / p_k,   v_k = -M w_k M / p_k,
!>   change       mean(u)              standard error   sqrt(var(u) / s)   (Hansen & Hurwitz)
!>   allowance    second_order_half sqrt(|V_ii V_jj|), V = mean(v) (negative semi-definite: its
!>                off-diagonal entries are bounded so), with its own standard error
!>   bound        coverage (|change| + allowance + spread_factor (the standard errors)),
!> the sums exact (no standard error) when every row is in the sample; coverage for the terms of
!> third order and the mobility's linearisation (5 %; every row: the bound within 1.0002 of the
!> true error when the first order dominates).
module beadmob_operator_error_bar
  use beadmob_kinds, only: dp, i8
  use beadmob_mobility, only: coefficient_entries, coefficient_lengths
  implicit none
  private
  public :: operator_error_t, estimate_operator_error, spread_factor, second_order_mid, second_order_half, coverage

  !> Standard errors added to the change: three (two left the largest entry of a turned cone's
  !> 64-draw bar below its true error in 8 % of the samples, bench/error_estimate/operator_error.md)
  real(dp), parameter :: spread_factor = 3.0_dp
  !> The second order's ratio rho taken as 2.5 +- 2.5 (0 .. 5; measured 0.5 .. 3.9)
  real(dp), parameter :: second_order_mid = 2.5_dp, second_order_half = 2.5_dp
  real(dp), parameter :: coverage = 1.05_dp

  type :: operator_error_t
    logical :: available = .false.
    integer(i8) :: n_beads = 0
    integer :: rows = 0
    !> Estimated zeta(A) - zeta(A~) (first order and the second's mid value, model coordinates),
    !> its standard error, and the second order's S^-1 sum W
    real(dp) :: friction_change(6, 6) = 0.0_dp, friction_standard_error(6, 6) = 0.0_dp
    real(dp) :: friction_second(6, 6) = 0.0_dp
    !> Estimated M(A) - M(A~), body frame, its standard error and the bound of |M(A~) - M(A)|
    real(dp) :: mobility_change(6, 6) = 0.0_dp, mobility_standard_error(6, 6) = 0.0_dp
    real(dp) :: mobility_error(6, 6) = 0.0_dp
    !> The bound on the scale sqrt(M_ii M_jj) (error_estimate.f90's measure) and its largest
    !> entry; the largest on the scale of the largest mobility (friction) entry
    real(dp) :: scaled_mobility_error(6, 6) = 0.0_dp
    real(dp) :: largest = 0.0_dp
    real(dp) :: relative_mobility = 0.0_dp, relative_friction = 0.0_dp
    real(dp) :: coefficient_error(5) = 0.0_dp          ! of mu11 ... mu51, absolute
    real(dp) :: scaled_coefficient_error(5) = 0.0_dp
    real(dp) :: seconds = 0.0_dp
  end type operator_error_t

contains

  !> terms, second (6, 6, s): the draws' t_k and w_k in model coordinates, probability: each
  !> draw's p_k, every_row: the draws are the N beads once each; friction and mobility (its
  !> inverse): model coordinates; body_axes: the columns of the body frame; reference_length: L of
  !> the paper's coefficients.
  pure function estimate_operator_error(terms, second, probability, every_row, n_beads, friction, mobility, body_axes, &
                                        reference_length) result(e)
    real(dp), intent(in) :: terms(:, :, :), second(:, :, :), probability(:), friction(6, 6), mobility(6, 6), &
                            body_axes(3, 3), reference_length
    logical, intent(in) :: every_row
    integer(i8), intent(in) :: n_beads
    type(operator_error_t) :: e
    real(dp) :: rotation(6, 6), u(6, 6, size(terms, 3)), v(6, 6, size(terms, 3)), z(6, 6, size(terms, 3)), &
                w(6, 6, size(terms, 3)), scale(6, 6), diagonal(6), body(6, 6), second_change(6, 6), second_error(6, 6), &
                allowance(6, 6), allowance_error(6, 6), friction_second_error(6, 6), dummy(6, 6)
    integer :: k, s, i, j

    s = size(terms, 3)
    e%n_beads = n_beads
    e%rows = s
    if (s == 0) return
    e%available = .true.
    rotation = 0.0_dp
    rotation(1:3, 1:3) = transpose(body_axes)
    rotation(4:6, 4:6) = transpose(body_axes)
    do k = 1, s
      z(:, :, k) = (terms(:, :, k) + second_order_mid * second(:, :, k)) / probability(k)
      w(:, :, k) = second(:, :, k) / probability(k)
      u(:, :, k) = -matmul(rotation, matmul(matmul(mobility, matmul(z(:, :, k), mobility)), transpose(rotation)))
      v(:, :, k) = -matmul(rotation, matmul(matmul(mobility, matmul(w(:, :, k), mobility)), transpose(rotation)))
    end do
    call mean_and_error(z, e%friction_change, e%friction_standard_error)
    call mean_and_error(w, e%friction_second, friction_second_error)
    call mean_and_error(u, e%mobility_change, e%mobility_standard_error)
    call mean_and_error(v, second_change, second_error)
    diagonal = [(sqrt(abs(second_change(i, i))), i = 1, 6)]
    allowance = second_order_half * spread(diagonal, 2, 6) * spread(diagonal, 1, 6)
    diagonal = [(sqrt(second_error(i, i)), i = 1, 6)]
    allowance_error = second_order_half * spread(diagonal, 2, 6) * spread(diagonal, 1, 6)
    e%mobility_error = coverage * (abs(e%mobility_change) + allowance + &
                                   spread_factor * (e%mobility_standard_error + allowance_error))
    body = matmul(rotation, matmul(mobility, transpose(rotation)))
    diagonal = [(sqrt(abs(body(i, i))), i = 1, 6)]
    scale = spread(diagonal, 2, 6) * spread(diagonal, 1, 6)
    e%scaled_mobility_error = e%mobility_error / scale
    e%largest = maxval(e%scaled_mobility_error)
    e%relative_mobility = maxval(e%mobility_error) / maxval(abs(body))
    ! the friction's: the same allowance on the friction's own W
    diagonal = [(sqrt(abs(e%friction_second(i, i))), i = 1, 6)]
    dummy = second_order_half * spread(diagonal, 2, 6) * spread(diagonal, 1, 6)
    e%relative_friction = coverage * maxval(abs(e%friction_change) + dummy + spread_factor * e%friction_standard_error) / &
                          maxval(abs(friction))
    do k = 1, 5
      i = coefficient_entries(1, k)
      j = coefficient_entries(2, k)
      e%scaled_coefficient_error(k) = e%scaled_mobility_error(i, j)
      e%coefficient_error(k) = coefficient_lengths(k, reference_length) * e%mobility_error(i, j)
    end do

  contains

    !> The mean of the draws' values (each already divided by its probability: an estimate of the
    !> sum over all beads), and its standard error (draws with replacement, Hansen & Hurwitz
    !> 1943; the systematic draws' is at most about this); none when every row was drawn.
    pure subroutine mean_and_error(values, total, standard_error)
      real(dp), intent(in) :: values(:, :, :)
      real(dp), intent(out) :: total(6, 6), standard_error(6, 6)
      real(dp) :: variance(6, 6)
      integer :: r
      total = sum(values, dim=3) / s
      standard_error = 0.0_dp
      if (s < 2 .or. every_row) return
      variance = 0.0_dp
      do r = 1, s
        variance = variance + (values(:, :, r) - total)**2
      end do
      standard_error = sqrt(variance / (s - 1) / s)
    end subroutine mean_and_error
  end function estimate_operator_error
end module beadmob_operator_error_bar
