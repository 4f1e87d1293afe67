!> Before the friction job allocates anything large: its estimate (beadmob_job_estimate), printed
!> by the dry run (`beadmob --estimate job.nml`, PETSc option -estimate) and compared with the
!> memory each rank can have. A job that would not fit is refused here with one message, on every
!> rank together, instead of failing later in an allocation or being killed by the kernel.
!> Its options (read by command_line.F90 into the run's config): -estimate (dry run),
!> -estimate_ranks P (the estimate for P ranks instead of the ranks of this run), -memory_limit G
!> (GiB a rank may use; default: what the node has available, shared by the ranks on the node).
module beadmob_job_planning
#include "petsc/finclude/petscsys.h"
  use petscsys
  use beadmob_kinds, only: dp
  use beadmob_errors, only: error_t, raise
  use beadmob_strings, only: str, either, str_significant
  use beadmob_pfft_operator, only: pfft_expected_error
  use beadmob_parallel, only: run_context_t, agree_on_error
  use beadmob_resources, only: available_memory_bytes, online_processors
  use beadmob_input_config, only: run_config_t
  use beadmob_job_plan, only: job_plan_t, make_job_plan
  use beadmob_job_estimate, only: job_estimate_t
  use beadmob_progress, only: progress_line
  implicit none
  private
  public :: plan_friction_job

  real(dp), parameter :: gib = 2.0_dp**30

contains

  !> Collective. The plan of the friction job of `centres` with the run's settings (job_plan.f90),
  !> for the ranks of the run or -estimate_ranks P; with -estimate (config%dry_run) it is printed
  !> (rank 0): the caller stops there. Otherwise a job whose peak memory per rank exceeds the
  !> memory available to a rank (or -memory_limit) is refused (err on every rank).
  subroutine plan_friction_job(ctx, config, centres, plan, err)
    type(run_context_t), intent(in) :: ctx
    type(run_config_t), intent(in) :: config
    real(dp), intent(in) :: centres(:, :)
    type(job_plan_t), intent(out) :: plan
    type(error_t), intent(inout) :: err
    logical :: ranks_given, limit_given
    integer :: ranks
    real(dp) :: limit, available, node_available, oversubscription
    PetscErrorCode :: ierr

    ranks_given = config%estimate_ranks > 0
    ranks = merge(config%estimate_ranks, ctx%n_ranks, ranks_given)
    limit_given = config%memory_limit_gib > 0.0_dp

    ! More ranks than processors on a node share them: the times grow by that factor (the largest
    ! over the nodes). An estimate for -estimate_ranks assumes a processor per rank.
    oversubscription = real(ctx%ranks_on_node, dp) / online_processors()
    call MPI_Allreduce(MPI_IN_PLACE, oversubscription, 1, MPI_DOUBLE_PRECISION, MPI_MAX, ctx%comm, ierr)
    if (ranks_given) oversubscription = 1.0_dp
    ! The rigid motions turn about the centre of mass (as body_frame.f90 computes it).
    call make_job_plan(ctx, config%hydrodynamics, centres, sum(centres, dim=2) / size(centres, 2), ranks, oversubscription, &
                       plan, err)
    if (err%failed) return   ! the same settings and beads everywhere (agreed on inside where not)

    ! What a rank may use: the node's available memory shared by the ranks on it (the least over
    ! the nodes), or -memory_limit.
    node_available = available_memory_bytes()
    available = node_available / ctx%ranks_on_node
    if (node_available <= 0.0_dp) available = huge(1.0_dp)   ! unknown: no refusal
    call MPI_Allreduce(MPI_IN_PLACE, available, 1, MPI_DOUBLE_PRECISION, MPI_MIN, ctx%comm, ierr)
    limit = available
    if (limit_given) limit = config%memory_limit_gib * gib

    associate (estimate => plan%estimate)
      if (config%dry_run) then
        if (ctx%rank == 0) call print_estimate(plan, limit, limit_given, ranks_given, config%hydrodynamics%pfft_stencil)
        return
      end if
      call progress_line(config%hydrodynamics%progress .and. ctx%rank == 0, 'estimate: ' // gib_text(estimate%peak) // &
                         ' GiB per rank, ' // seconds_text(estimate%seconds_total) // ' (beadmob --estimate: the parts)')
      if (estimate%peak > limit) &
        call raise(err, 'the job needs about ' // gib_text(estimate%peak) // ' GiB per rank on ' // str(ranks) // &
                   ' ranks (' // trim(breakdown(estimate)) // ') and would take about ' // &
                   seconds_text(estimate%seconds_total) // ', more than the ' // gib_text(limit) // &
                   ' GiB a rank can have' // either(limit_given, ' (-memory_limit)', ' (available on this node)') // &
                   '; refused before allocating. Use more ranks or nodes, a smaller model or a lower ' // &
                   'multipole_order (beadmob --estimate shows the estimate)')
    end associate
    call agree_on_error(ctx, err)
  end subroutine plan_friction_job

  subroutine print_estimate(plan, limit, limit_given, ranks_given, config_stencil)
    type(job_plan_t), intent(in) :: plan
    real(dp), intent(in) :: limit
    logical, intent(in) :: limit_given, ranks_given
    integer, intent(in) :: config_stencil   ! the pfft operator's stencil
    associate (e => plan%estimate)
    write (*, '(a)') 'beadmob: estimate for ' // str(e%n_ranks) // ' rank(s) (dry run: nothing built, no result file)'
    write (*, '(a)') '  beads:                ' // str(e%n_beads) // ' (' // str(e%solve_beads) // ' in the solve)'
    write (*, '(a)') '  unknowns:             ' // str(e%unknowns) // ' (' // str(e%unknowns_per_bead) // ' per bead)'
    if (e%operator_name == 'fft' .or. e%operator_name == 'pfft') then
      write (*, '(a)') '  operator:             ' // trim(e%operator_name) // ', padded box ' // str(e%fft_box(1)) // ' x ' // str(e%fft_box(2)) // &
        ' x ' // str(e%fft_box(3)) // trim(merge(' by mirror class', '                ', e%by_mirror_class)) // &
        trim(replication_text(e))
    else
      write (*, '(a)') '  operator:             ' // trim(e%operator_name)
    end if
    if (allocated(plan%operator_reason)) write (*, '(a)') '  chosen:               ' // plan%operator_reason
    if (e%operator_name == 'pfft') write (*, '(a)') '  pfft near radius:     ' // str_significant(plan%pfft_near_radius, 3) // &
      ' d (far field''s expected error ' // str_significant(pfft_expected_error(config_stencil, plan%pfft_near_radius), 2) // &
      ', docs/theory.md T16)'
    write (*, '(a)') '  canonical blocks:     ' // str(e%canonical_blocks) // ' (from the axial table)'
    write (*, '(a)') '  memory per rank:      ' // gib_text(e%peak) // ' GiB (' // trim(breakdown(e)) // ')'
    if (limit < huge(1.0_dp)) then
      write (*, '(a)') '  memory a rank can have: ' // gib_text(limit) // ' GiB' // either(limit_given, ' (-memory_limit)', &
        ' (available on this node / its ranks)') // either(e%peak <= limit, ' -> fits', ' -> does NOT fit: refused')
      if (ranks_given) write (*, '(a)') '  (-estimate_ranks: the ranks of this dry run share the node, not those of the job)'
    end if
    write (*, '(a)') '  expected wall time:   ' // seconds_text(e%seconds_total) // ' (blocks ' // &
      seconds_text(e%seconds_blocks) // ', solve ' // seconds_text(e%seconds_solve) // ': ' // str(e%n_solves) // &
      ' solve(s)' // either(e%strain_solves > 0, ' + ' // str(e%strain_solves) // ' strain solves', '') // &
      ' of ~' // str(e%iterations) // ' CG iterations' // &
      either(e%seconds_companion > 0, ', error bar''s companion ' // seconds_text(e%seconds_companion), '') // ')'
    if (plan%body_frame) write (*, '(a)') '  solve frame:          the body frame (' // str(plan%n_solves) // &
      ' solves instead of ' // str(plan%lab_solves) // ' in the model''s coordinates)'
    end associate
  end subroutine print_estimate

  function breakdown(e) result(text)
    type(job_estimate_t), intent(in) :: e
    character(len=256) :: text
    text = 'base ' // gib_text(e%base) // ', geometry ' // gib_text(e%geometry) // ', blocks ' // gib_text(e%blocks) // &
           ', ' // kernel_name(e%operator_name) // ' ' // gib_text(e%kernel) // &
           ', FFT buffer ' // gib_text(e%fft_buffer) // ', transposes ' // gib_text(e%transposes) // &
           ', vectors ' // gib_text(e%vectors) // either(e%companion > 0, ', companion ' // gib_text(e%companion), '')
  end function breakdown

  !> How the products share the ranks: the box's frequencies split over them, or the operator
  !> whole on each (replicated_operator.F90).
  pure function replication_text(e) result(text)
    type(job_estimate_t), intent(in) :: e
    character(len=:), allocatable :: text
    if (e%replicated) then
      text = ', whole on every rank (a batch of products dealt out to the ranks)'
    else
      text = ' (at most ' // str(e%frequency_lines) // ' ranks hold frequencies, more ranks do not pay)'
    end if
  end function replication_text

  !> What the estimate's kernel term holds for each operator.
  pure function kernel_name(operator_name) result(text)
    character(len=*), intent(in) :: operator_name
    character(len=:), allocatable :: text
    select case (operator_name)
    case ('fft', 'pfft')
      text = 'FFT kernel'
    case ('dense')
      text = 'MUMPS entries and factor'
    case default
      text = 'block table'
    end select
  end function kernel_name

  function gib_text(bytes) result(text)
    real(dp), intent(in) :: bytes
    character(len=:), allocatable :: text
    character(len=32) :: buffer
    if (bytes / gib < 1.0e5_dp) then
      write (buffer, '(f0.2)') bytes / gib
      if (buffer(1:1) == '.') buffer = '0' // buffer(:len(buffer) - 1)   ! the blank at its end makes room
    else
      write (buffer, '(es9.2)') bytes / gib
    end if
    text = trim(adjustl(buffer))
  end function gib_text

  function seconds_text(seconds) result(text)
    real(dp), intent(in) :: seconds
    character(len=:), allocatable :: text
    character(len=32) :: buffer
    if (seconds < 1.0_dp) then   ! small jobs: milliseconds, which decide between their operators
      write (buffer, '(f0.3, a)') seconds, ' s'
    else if (seconds < 120.0_dp) then
      write (buffer, '(f0.1, a)') seconds, ' s'
    else if (seconds < 7200.0_dp) then
      write (buffer, '(f0.1, a)') seconds / 60, ' min'
    else
      write (buffer, '(es9.2, a)') seconds / 3600, ' h'
    end if
    if (buffer(1:1) == '.') buffer = '0' // buffer(:len(buffer) - 1)   ! the blank at its end makes room
    text = trim(adjustl(buffer))
  end function seconds_text
end module beadmob_job_planning
