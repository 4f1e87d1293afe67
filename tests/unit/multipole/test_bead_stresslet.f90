!> Tests the beads' own stresslets at order L = 1 (src/multipole/bead_stresslet.f90, docs/theory.md
!> T19). CTest: test_bead_stresslet_np1 and test_bead_stresslet_np2.
!> References, each an independent route to the same numbers:
!> - a single sphere whose surface moves as E . y exerts (20/3) pi eta a^3 E (Einstein 1906;
!>   Batchelor 1970, eq. 5.8): the order-2 single-bead block solved for its strain density;
!> - the closed-form Faxen velocity and rotation of a strained bead's field (strained_bead_motion)
!>   against the order-2 Galerkin pair blocks computed by quadrature (pair_blocks.f90), whose rows
!>   of the order-1 densities applied to the strain density are that same projection;
!> - the moment form of the pair sum (stresslet_pattern_response) against the pair-by-pair sum of
!>   the closed form.
program test_bead_stresslet
  use beadmob_kinds, only: dp, i8
  use beadmob_testing, only: test_suite_t, start_tests, finish_tests, check, check_close
  use beadmob_multipole_basis, only: multipole_basis_t, make_multipole_basis
  use beadmob_pair_blocks, only: pair_block, self_block, rigid_projection
  use beadmob_linear_flow, only: n_strain_modes, strain_mode, strain_projection
  use beadmob_bead_stresslet, only: bead_self_stresslet, strained_bead_motion, stresslet_pattern_response
  use beadmob_lapack, only: dpotrf, dpotrs
  implicit none
  type(test_suite_t) :: suite
  type(multipole_basis_t) :: basis, order_one
  real(dp), allocatable :: self(:, :), factor(:, :), own(:, :), density(:, :), block(:, :), projection(:, :)
  real(dp), allocatable :: projection_one(:, :), centres(:, :), response(:, :), direct(:, :)
  real(dp) :: displacements(3, 6), velocity(3), rotation(3), galerkin(6), closed(6), worst, largest, motion(6)
  integer, allocatable :: low(:)
  integer :: k, l, p, info, nb
  integer(i8) :: i, j

  suite = start_tests('test_bead_stresslet')
  ! The order-2 basis (16 functions per bead): its strain densities and its order-1 rows.
  basis = make_multipole_basis(2, 0)
  nb = basis%size
  allocate (self(nb, nb), own(nb, n_strain_modes), block(nb, nb), projection(nb, 6))
  call self_block(basis, self)
  call strain_projection(basis, own)
  call rigid_projection(basis, projection)
  factor = self
  density = own
  call dpotrf('L', nb, factor, nb, info)
  call dpotrs('L', nb, n_strain_modes, factor, nb, density, nb, info)
  call check(suite, info == 0, 'single-bead block positive definite')
  do k = 1, n_strain_modes
    do l = 1, n_strain_modes
      call check(suite, abs(dot_product(own(:, k), density(:, l)) - merge(bead_self_stresslet, 0.0_dp, k == l)) < &
                 1.0e-12_dp * bead_self_stresslet, 'one strained bead: stresslet (20/3) pi a^3 E')
    end do
  end do
  low = pack([(p, p = 1, nb)], basis%degree == 1)

  ! Touching on the lattice (axis, face and body diagonals scaled to contact), apart, off the lattice.
  displacements(:, 1) = [1.0_dp, 0.0_dp, 0.0_dp]
  displacements(:, 2) = [1.0_dp, 1.0_dp, 0.0_dp]
  displacements(:, 3) = [1.0_dp, 1.0_dp, 1.0_dp] / sqrt(3.0_dp)
  displacements(:, 4) = [2.0_dp, -1.0_dp, 3.0_dp]
  displacements(:, 5) = [0.3_dp, -1.1_dp, 0.45_dp]
  displacements(:, 6) = [-4.2_dp, 2.9_dp, -0.7_dp]
  do p = 1, size(displacements, 2)
    ! Row bead at R_i, column bead (the strained one) at R_i - displacement.
    call pair_block(basis, displacements(:, p), block)
    worst = 0.0_dp
    largest = 0.0_dp   ! some modes give no motion at all on an axis: one scale for the five
    do k = 1, n_strain_modes
      galerkin = matmul(block(low, :), density(:, k))
      call strained_bead_motion(strain_mode(k), displacements(:, p), velocity, rotation)
      closed = matmul(projection(low, :), [velocity, rotation])
      worst = max(worst, maxval(abs(galerkin - closed)))
      largest = max(largest, maxval(abs(galerkin)))
    end do
    worst = worst / largest
    call check(suite, worst < 1.0e-10_dp, 'strained bead at r = (' // trim(vector_text(displacements(:, p))) // &
               '): closed form = Galerkin pair block')
  end do

  ! A cluster: a 3 x 3 x 2 lattice block and two beads off it.
  allocate (centres(3, 20))
  p = 0
  do k = 0, 2
    do l = 0, 2
      centres(:, p + 1) = [real(k, dp), real(l, dp), 0.0_dp]
      centres(:, p + 2) = [real(k, dp), real(l, dp), 1.0_dp]
      p = p + 2
    end do
  end do
  centres(:, 19) = [1.3_dp, 0.4_dp, 2.1_dp]
  centres(:, 20) = [-1.2_dp, 1.7_dp, 0.6_dp]
  order_one = make_multipole_basis(1, 0)
  allocate (projection_one(order_one%size, 6), response(6 * 20, n_strain_modes), direct(6 * 20, n_strain_modes))
  call rigid_projection(order_one, projection_one)
  call stresslet_pattern_response(centres, 1_i8, 20_i8, projection_one, response)
  do k = 1, n_strain_modes
    do j = 1, 20
      motion = 0.0_dp
      do i = 1, 20
        if (i == j) cycle
        call strained_bead_motion(strain_mode(k), centres(:, j) - centres(:, i), velocity, rotation)
        motion = motion + [velocity, rotation]
      end do
      direct(6 * j - 5:6 * j, k) = matmul(projection_one, motion)
    end do
  end do
  worst = maxval(abs(response - direct)) / maxval(abs(direct))
  call check(suite, worst < 1.0e-13_dp, 'pair sum by moments = pair by pair')
  ! Rows 7..12 of the same pair sum taken over beads 2..3 only (a rank's share).
  call stresslet_pattern_response(centres, 2_i8, 2_i8, projection_one, response(1:12, :))
  call check(suite, maxval(abs(response(1:12, :) - direct(7:18, :))) < 1.0e-13_dp * maxval(abs(direct)), &
             'a share of the beads gives its rows')
  call finish_tests(suite)

contains

  function vector_text(v) result(text)
    real(dp), intent(in) :: v(3)
    character(len=64) :: text
    write (text, '(f0.3, ", ", f0.3, ", ", f0.3)') v
  end function vector_text
end program test_bead_stresslet
