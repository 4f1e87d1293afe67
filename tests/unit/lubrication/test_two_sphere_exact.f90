!> Tests src/lubrication/two_sphere_exact.f90 near contact.
!> CTest: test_near_contact_np1 and test_near_contact_np2 (the program keeps the test's name, test_near_contact).
!> Near contact (gaps 1e-6 ... 1e-2 d) the exact two-sphere series of src/lubrication must stay
!> finite, cheap and right: the squeezing series (Maude 1961) against the lubrication asymptote of
!> Jeffrey & Onishi, J. Fluid Mech. 139, 261 (1984), for equal spheres with xi = gap / a:
!>   X11A - X12A = 1 / (2 xi) + (9/20) ln(1/xi) + C + O(xi ln xi)
!> (X11A ~ 1/(4 xi) + (9/40) ln(1/xi), X12A ~ -X11A at leading orders); the rigid-doublet
!> series (Stimson & Jeffery 1926) finite and decreasing towards its contact value 0.645 as the
!> gap closes (no singularity without relative motion); the counter-rotation series (Jeffery 1915)
!> towards its contact value zeta(3) (sum 1/n^3, the series' own alpha -> 0 limit).
program test_near_contact
  use beadmob_kinds, only: dp
  use beadmob_testing, only: test_suite_t, start_tests, finish_tests, check, check_close
  use beadmob_strings, only: str
  use beadmob_two_sphere_exact, only: stimson_jeffery, maude_approach, jeffery_counter_rotation
  implicit none
  real(dp), parameter :: a = 0.5_dp, zeta3 = 1.2020569031595942_dp
  real(dp), parameter :: gaps(5) = [1.0e-2_dp, 1.0e-3_dp, 1.0e-4_dp, 1.0e-5_dp, 1.0e-6_dp]
  type(test_suite_t) :: suite
  real(dp) :: xi, squeeze(5), rest(5), translate(5), rotate(5)
  integer :: k

  suite = start_tests('test_near_contact')
  do k = 1, size(gaps)
    xi = gaps(k) / a
    squeeze(k) = maude_approach(2.0_dp * a + gaps(k), a)
    translate(k) = stimson_jeffery(2.0_dp * a + gaps(k), a)
    rotate(k) = jeffery_counter_rotation(2.0_dp * a + gaps(k), a)
    rest(k) = squeeze(k) - 1.0_dp / (2.0_dp * xi) - 0.45_dp * log(1.0_dp / xi)
    write (*, '(a, es8.1, a, 3es22.14, a, f12.8)') 'gap ', gaps(k), ': squeeze, rigid, counter-rotation ', &
      squeeze(k), translate(k), rotate(k), '; squeeze - asymptote ', rest(k)
  end do
  ! Leading order: 2 xi X -> 1 (the log term makes it 1 + 0.9 xi ln(1/xi) + ...).
  call check_close(suite, squeeze(5) * 2.0_dp * gaps(5) / a, 1.0_dp, 3.0e-5_dp, 'squeeze at gap 1e-6: 1/(2 xi) leads')
  ! What remains after the two singular terms converges to a constant as the gap closes.
  do k = 2, size(gaps) - 1
    call check(suite, abs(rest(k + 1) - rest(k)) < abs(rest(k) - rest(k - 1)), &
               'squeeze minus asymptote converges, gap ' // str(gaps(k + 1)))
  end do
  call check(suite, abs(rest(5) - rest(4)) < 1.0e-3_dp, 'squeeze minus asymptote constant to 1e-3 below gap 1e-5')
  call check(suite, all(translate(2:) < translate(:4)), 'rigid pair drag decreases as the gap closes')
  call check(suite, abs(translate(5) - 0.645_dp) < 5.0e-4_dp, 'rigid pair drag at gap 1e-6: literature 0.645')
  call check(suite, all(rotate(2:) > rotate(:4)), 'counter-rotation torque grows as the gap closes')
  call check_close(suite, rotate(5), zeta3, 1.0e-4_dp, 'counter-rotation at gap 1e-6: zeta(3)')
  call finish_tests(suite)
end program test_near_contact
