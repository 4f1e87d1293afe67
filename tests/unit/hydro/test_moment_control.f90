!> Tests src/hydro/moment_control.f90 on bead models of a sphere of radius R made here (the nodes
!> (i + offset) d inside it, the offsets the continuum job's Halton points, lattice_fill.f90). CTest: test_moment_control_np1/np2.
!> - The premise: over random offsets the beads' volume N d^3 and second moment sum x^2 d^3 average
!>   to the sphere's, 4 pi R^3 / 3 and 4 pi R^5 / 15 (closed forms).
!> - A value that is an exact linear function of the sample's moment features (its mean over
!>   random offsets therefore 1 exactly): the plain level means miss 1 by the offsets' scatter, the
!>   moment-controlled ones recover it to rounding.
!> - A value that is noise independent of the moments: the control moves no level mean by more
!>   than its standard error and does not shrink the variance (factor >= 1).
!> - Fewer samples than 3 per feature beyond the levels: no shift, factor 1.
program test_moment_control
  use beadmob_kinds, only: dp, i8
  use beadmob_testing, only: test_suite_t, start_tests, finish_tests, check, check_close
  use beadmob_random_vectors, only: hash_uniform
  use beadmob_lattice_fill, only: offset_sequence
  use beadmob_moment_control, only: moment_features, body_moment_features, moment_control_shift, n_moment_features
  use beadmob_continuum_fit, only: level_mean
  use beadmob_strings, only: str
  implicit none
  real(dp), parameter :: pi = acos(-1.0_dp), radius = 1.0_dp
  integer, parameter :: levels = 3, per_level = 24, n = levels * per_level
  real(dp), parameter :: diameters(levels) = [0.4_dp, 0.3_dp, 0.23_dp]
  type(test_suite_t) :: suite
  real(dp) :: moments(13, n), body(13), features(n_moment_features, n), body_features(n_moment_features)
  real(dp) :: linear(n), noise(n), shift(n), factor, mean, error, corrected, corrected_error
  real(dp) :: shifts(2, n), factors(2), noise_shift(n), noise_factor
  real(dp) :: plain_miss, controlled_miss, mean_volume, mean_second
  integer :: s, k, large_n
  integer, allocatable :: level(:)

  suite = start_tests('test_moment_control')
  body = 0.0_dp
  body(1) = 4.0_dp * pi * radius**3 / 3.0_dp
  body([5, 9, 13]) = 4.0_dp * pi * radius**5 / 15.0_dp
  allocate (level(n))
  do s = 1, n
    level(s) = (s - 1) / per_level + 1
    moments(:, s) = sphere_bead_moments(diameters(level(s)), s)
  end do

  ! The premise, on 400 offsets at the coarsest level (their scatter there is largest).
  large_n = 400
  mean_volume = 0.0_dp
  mean_second = 0.0_dp
  do s = 1, large_n
    associate (m => sphere_bead_moments(diameters(1), 1000 + s))
      mean_volume = mean_volume + m(1) / large_n
      mean_second = mean_second + (m(5) + m(9) + m(13)) / 3.0_dp / large_n
    end associate
  end do
  call check_close(suite, mean_volume, body(1), 2.0e-3_dp, 'mean bead volume over offsets: 4 pi R^3 / 3')
  call check_close(suite, mean_second, body(5), 4.0e-3_dp, 'mean bead second moment: 4 pi R^5 / 15')

  features = moment_features(moments, body)
  body_features = body_moment_features(body)
  call check_close(suite, body_features(1), 1.0_dp, 1.0e-14_dp, 'the body''s relative volume is 1')

  ! A value linear in the features: its offset average is 1 (the features' averages are the body's).
  linear = 1.0_dp + 0.4_dp * (features(1, :) - body_features(1)) - 0.25_dp * (features(5, :) - body_features(5)) &
           + 0.1_dp * (features(7, :) - body_features(7))
  call one_shift(linear, level, features, shift, factor)
  plain_miss = 0.0_dp
  controlled_miss = 0.0_dp
  do k = 1, levels
    call level_mean(pack(linear, level == k), mean, error)
    call level_mean(pack(linear - shift, level == k), corrected, corrected_error)
    plain_miss = max(plain_miss, abs(mean - 1.0_dp))
    controlled_miss = max(controlled_miss, abs(corrected - 1.0_dp))
  end do
  call check(suite, plain_miss > 1.0e-4_dp, 'linear value: the plain level means miss its offset average')
  call check(suite, controlled_miss < 1.0e-6_dp * plain_miss, &
             'linear value: the moment-controlled means recover it: miss ' // str(controlled_miss) // &
             ' against the plain ' // str(plain_miss))
  call check(suite, factor >= 1.0_dp, 'linear value: the variance factor counts the regression''s parameters')

  ! Noise unrelated to the moments.
  do s = 1, n
    noise(s) = 1.0_dp + 0.01_dp * (hash_uniform(int(7919 * s, i8)) - 0.5_dp)
  end do
  call one_shift(noise, level, features, shift, factor)
  noise_shift = shift
  noise_factor = factor
  call check(suite, factor >= 1.0_dp, 'noise: the variance is not shrunk')
  do k = 1, levels
    call level_mean(pack(noise, level == k), mean, error)
    call level_mean(pack(noise - shift, level == k), corrected, corrected_error)
    call check(suite, abs(corrected - mean) <= error, 'noise: a level mean moves less than its standard error')
  end do

  ! Too few samples: 4 per level, 12 - 3 < 3 x 10.
  call one_shift(linear(1:12), [1, 1, 1, 1, 2, 2, 2, 2, 3, 3, 3, 3], features(:, 1:12), shift(1:12), factor)
  call check(suite, all(shift(1:12) == 0.0_dp) .and. factor == 1.0_dp, 'too few samples: no regression')

  ! Several targets at once share the features' factors, each with its own ridge: as one at a time.
  call one_shift(linear, level, features, shift, factor)
  call moment_control_shift(reshape([linear, noise], [2, n], order=[2, 1]), level, features, body_features, shifts, &
                            factors)
  call check(suite, maxval(abs(shifts(1, :) - shift)) <= 1.0e-12_dp * maxval(abs(shift)) .and. &
             abs(factors(1) - factor) <= 1.0e-12_dp, 'two targets at once: the linear one''s shift as alone')
  call check(suite, maxval(abs(shifts(2, :) - noise_shift)) <= 1.0e-12_dp * max(maxval(abs(noise_shift)), 1.0e-300_dp) &
             .and. abs(factors(2) - noise_factor) <= 1.0e-12_dp, 'two targets at once: the noise''s shift as alone')

  call finish_tests(suite)

contains

  !> moment_control_shift of one target.
  subroutine one_shift(target, sample_level, sample_features, target_shift, target_factor)
    real(dp), intent(in) :: target(:), sample_features(:, :)
    integer, intent(in) :: sample_level(:)
    real(dp), intent(out) :: target_shift(size(target)), target_factor
    real(dp) :: shifts_of_one(1, size(target)), factors_of_one(1)
    call moment_control_shift(reshape(target, [1, size(target)]), sample_level, sample_features, body_features, &
                              shifts_of_one, factors_of_one)
    target_shift = shifts_of_one(1, :)
    target_factor = factors_of_one(1)
  end subroutine one_shift

  !> Volume, first and second moments (body_moments_t's order) of the nodes (i + offset) d inside
  !> the sphere, the offset Halton point number j.
  function sphere_bead_moments(d, j_offset) result(m)
    real(dp), intent(in) :: d
    integer, intent(in) :: j_offset
    real(dp) :: m(13), offset(3), x(3)
    integer :: i, j, l, reach
    offset = offset_sequence(j_offset)
    reach = ceiling(radius / d) + 1
    m = 0.0_dp
    do l = -reach, reach
      do j = -reach, reach
        do i = -reach, reach
          x = ([i, j, l] + offset) * d
          if (sum(x**2) >= radius**2) cycle
          m(1) = m(1) + d**3
          m(2:4) = m(2:4) + x * d**3
          m(5:13) = m(5:13) + reshape(spread(x, 2, 3) * spread(x, 1, 3), [9]) * d**3
        end do
      end do
    end do
  end function sphere_bead_moments

end program test_moment_control
