!> Tests src/solvers/accuracy_choice.f90 on the tables of src/solvers/accuracy_rule.f90.
!> CTest: test_accuracy_choice_np1 and test_accuracy_choice_np2 (the program keeps the test's name, test_accuracy_choice).
!> The --accuracy rule (src/solvers/accuracy_choice.f90 on the generated tables of
!> accuracy_rule.f90): for every target the choice is the first candidate, in the stored order of
!> increasing measured cost, whose promised error meets it (checked here by a plain search of
!> the tables); a target no candidate meets gives the most accurate one (of equals the costliest),
!> flagged; shell candidates are skipped when the shell model is not allowed; bad targets are refused.
program test_accuracy_choice
  use beadmob_kinds, only: dp
  use beadmob_errors, only: error_t
  use beadmob_accuracy_rule, only: n_candidates, candidate_cost, candidate_order, candidate_rtol, &
                                   candidate_shell_layers, promised_error_plain, promised_error_lubricated
  use beadmob_accuracy_choice, only: accuracy_choice_t, choose_for_accuracy
  use beadmob_testing
  implicit none
  type(test_suite_t) :: suite
  type(accuracy_choice_t) :: choice
  type(error_t) :: err
  real(dp) :: targets(5), promised(n_candidates)
  real(dp), parameter :: bad_targets(3) = [0.0_dp, -1.0e-2_dp, 1.5_dp]
  integer :: k, t, expected
  logical :: lubrication, shell_allowed

  suite = start_tests('test_accuracy_choice')
  call check(suite, n_candidates >= 2, 'the rule has candidates')
  call check(suite, all(candidate_cost(2:) >= candidate_cost(:n_candidates - 1)), 'candidates stored by cost')
  call check(suite, all(candidate_order >= 1 .and. candidate_rtol > 0.0_dp .and. candidate_rtol < 1.0_dp .and. &
                        candidate_shell_layers >= 0), 'candidate settings are valid inputs')
  call check(suite, all(promised_error_plain > 0.0_dp .and. promised_error_lubricated > 0.0_dp), &
             'every promise is a positive error')

  targets = [0.5_dp, 1.0e-2_dp, 1.0e-3_dp, 1.0e-4_dp, 1.0e-6_dp]
  do t = 1, size(targets)
    do k = 0, 3
      lubrication = mod(k, 2) == 1
      shell_allowed = k < 2
      call choose_for_accuracy(targets(t), lubrication, shell_allowed, choice, err)
      expected = first_meeting(targets(t), lubrication, shell_allowed)
      call check(suite, .not. err%failed, 'a valid target is accepted')
      if (expected > 0) then
        call check(suite, choice%target_met .and. choice%expected_error <= targets(t) .and. &
                   choice%order == candidate_order(expected) .and. choice%krylov_rtol == candidate_rtol(expected) &
                   .and. choice%shell_layers == candidate_shell_layers(expected), &
                   'the cheapest candidate that meets the target is chosen')
      else
        expected = most_accurate(lubrication, shell_allowed)
        promised = promises(lubrication)
        call check(suite, .not. choice%target_met .and. choice%expected_error == promised(expected) &
                   .and. choice%order == candidate_order(expected) .and. &
                   choice%krylov_rtol == candidate_rtol(expected), &
                   'no candidate meets the target: the most accurate one (of equals the costliest), flagged')
      end if
      call check(suite, shell_allowed .or. choice%shell_layers == 0, 'no shell model when it is not allowed')
      call check(suite, choice%target == targets(t), 'the target is recorded')
    end do
  end do

  do t = 1, 3
    err = error_t()
    call choose_for_accuracy(bad_targets(t), .false., .true., choice, err)
    call check(suite, err%failed .and. index(err%message, 'between 0 and 1') > 0, 'a target outside (0, 1) is refused')
  end do
  call finish_tests(suite)

contains

  function promises(lubrication) result(values)
    logical, intent(in) :: lubrication
    real(dp) :: values(n_candidates)
    values = promised_error_plain
    if (lubrication) values = promised_error_lubricated
  end function promises

  !> The smallest promise among the allowed candidates; of equal ones the last (costliest).
  integer function most_accurate(lubrication, shell_allowed)
    logical, intent(in) :: lubrication, shell_allowed
    real(dp) :: values(n_candidates)
    integer :: j
    values = promises(lubrication)
    most_accurate = 0
    do j = 1, n_candidates
      if (.not. (shell_allowed .or. candidate_shell_layers(j) == 0)) cycle
      if (most_accurate == 0) then
        most_accurate = j
      else if (values(j) <= values(most_accurate)) then
        most_accurate = j
      end if
    end do
  end function most_accurate

  !> 0 when none meets the target.
  integer function first_meeting(target, lubrication, shell_allowed)
    real(dp), intent(in) :: target
    logical, intent(in) :: lubrication, shell_allowed
    real(dp) :: values(n_candidates)
    integer :: j
    values = promises(lubrication)
    first_meeting = 0
    do j = 1, n_candidates
      if (values(j) <= target .and. (shell_allowed .or. candidate_shell_layers(j) == 0)) then
        first_meeting = j
        return
      end if
    end do
  end function first_meeting
end program test_accuracy_choice
